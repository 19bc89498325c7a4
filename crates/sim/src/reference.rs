//! Reference models with known answers, shared by the tests and the benchmarks (diffsol's
//! habit): each implements [`SuspensionModel`] so that it goes through exactly the code path
//! of the real models.
//!
//! | model | states | known answer |
//! |---|---|---|
//! | [`DampedOscillator`] | `x_m, v_m_s` | closed-form damped response, piecewise over load steps |
//! | [`FirstOrderLag`] | `y_m` | exponential approach, piecewise over load steps |
//! | [`GasVolume`] | `n_mol` | isothermal fill/exhaust through a linear resistance: exponential |
//! | [`Runaway`] | `n_mol, x_m` | `n` hits zero at `n0 / leak`; `x` grows as `e^{a t}` |
//! | [`ToyQuarterCar`] | `x1_m, x2_m, v1_m_s, v2_m_s, n_mol` | none (a stand-in with the real stiffness structure, tire lift-off included) |
//!
//! [`load_step_run`] builds the benchmark's 25-minute load-step run.

use airsus_data::{Run, RunInputs, ValveState};
use airsus_model::{
    InitialCondition, InputSample, ModelError, NamedParameters, OutputSample, ParameterInfo,
    StateInfo, StateRole, SuspensionModel,
};

/// Standard gravity used by the reference models, m/s².
pub const G: f64 = 9.81;

fn unknown(model: &str, name: &str, info: &[ParameterInfo]) -> ModelError {
    ModelError::UnknownParameter {
        model: model.to_owned(),
        name: name.to_owned(),
        suggestion: None,
        valid: info.iter().map(|p| p.name.to_owned()).collect(),
    }
}

fn checked(
    model: &str,
    info: &[ParameterInfo],
    name: &str,
    value: f64,
) -> Result<usize, ModelError> {
    let i = info
        .iter()
        .position(|p| p.name == name)
        .ok_or_else(|| unknown(model, name, info))?;
    let p = &info[i];
    if !(value >= p.lower && value <= p.upper) {
        return Err(ModelError::ParameterOutOfRange {
            model: model.to_owned(),
            name: name.to_owned(),
            value,
            lower: p.lower,
            upper: p.upper,
            unit: p.unit.to_owned(),
        });
    }
    Ok(i)
}

const fn param(
    name: &'static str,
    unit: &'static str,
    description: &'static str,
    lower: f64,
    upper: f64,
) -> ParameterInfo {
    ParameterInfo::new(name, unit, description, (lower, upper), None)
}

// ---------------------------------------------------------------------------------------------

/// `m x'' + c x' + k x = g * wheel_load`: a damped linear oscillator driven by the load.
///
/// Outputs: `sensor_height_m = x`, `bellow_gauge_pa = k x / AREA`. Its "equilibrium" initial
/// state deliberately is not one: [`SuspensionModel::initial_state`] puts the mass at rest at
/// the height (or the pressure) of the initial condition, so the response starts with a
/// transient towards `x_eq = g * load / k`.
#[derive(Debug, Clone, PartialEq)]
pub struct DampedOscillator {
    pub mass_kg: f64,
    pub damping_n_s_per_m: f64,
    pub stiffness_n_per_m: f64,
}

impl DampedOscillator {
    pub const AREA_M2: f64 = 0.05;
    const INFO: &'static [ParameterInfo] = &[
        param("m", "kg", "mass", 1e-3, 1e6),
        param("c", "N s/m", "viscous damping", 0.0, 1e9),
        param("k", "N/m", "stiffness", 1e-3, 1e12),
    ];

    /// Tire-like: 520 kg on 1.8 MN/m (≈ 59 rad/s), damping ratio 0.2.
    pub fn tire_like() -> Self {
        let m: f64 = 520.0;
        let k: f64 = 1.8e6;
        Self {
            mass_kg: m,
            damping_n_s_per_m: 2.0 * 0.2 * (k * m).sqrt(),
            stiffness_n_per_m: k,
        }
    }

    /// Static deflection under a wheel load, m.
    pub fn equilibrium(&self, wheel_load_kg: f64) -> f64 {
        G * wheel_load_kg / self.stiffness_n_per_m
    }

    /// The exact state after `dt` seconds from `(x, v)` with the load held (underdamped case).
    pub fn propagate(&self, x: f64, v: f64, wheel_load_kg: f64, dt: f64) -> (f64, f64) {
        let (m, c, k) = (self.mass_kg, self.damping_n_s_per_m, self.stiffness_n_per_m);
        let xe = self.equilibrium(wheel_load_kg);
        let sigma = c / (2.0 * m);
        let wd = (k / m - sigma * sigma).sqrt();
        let a = x - xe;
        let b = (v + sigma * a) / wd;
        let (s, co) = (wd * dt).sin_cos();
        let e = (-sigma * dt).exp();
        (
            xe + e * (a * co + b * s),
            e * ((-sigma * a + wd * b) * co + (-sigma * b - wd * a) * s),
        )
    }

    /// The exact response at the sample times of `loads` (held between samples), from rest at
    /// `x0`: sampled `x`.
    pub fn exact_response(&self, time_s: &[f64], loads: &[f64], x0: f64) -> Vec<f64> {
        let mut out = Vec::with_capacity(time_s.len());
        let (mut x, mut v) = (x0, 0.0);
        for k in 0..time_s.len() {
            if k > 0 {
                (x, v) = self.propagate(x, v, loads[k - 1], time_s[k] - time_s[k - 1]);
            }
            out.push(x);
        }
        out
    }
}

impl SuspensionModel for DampedOscillator {
    fn name(&self) -> &'static str {
        "ref-oscillator"
    }
    fn description(&self) -> &'static str {
        "reference: damped linear oscillator driven by the wheel load (analytic solution)"
    }
    fn states(&self) -> &[StateInfo] {
        const STATES: &[StateInfo] = &[
            StateInfo::new("x_m", "m", StateRole::Position),
            StateInfo::new("v_m_s", "m/s", StateRole::Velocity),
        ];
        STATES
    }
    fn parameters(&self) -> &dyn NamedParameters {
        self
    }
    fn parameters_mut(&mut self) -> &mut dyn NamedParameters {
        self
    }
    fn rhs(&self, _t: f64, x: &[f64], u: &InputSample, dx: &mut [f64]) {
        dx[0] = x[1];
        dx[1] =
            (G * u.wheel_load_kg - self.damping_n_s_per_m * x[1] - self.stiffness_n_per_m * x[0])
                / self.mass_kg;
    }
    fn output(&self, x: &[f64], _u: &InputSample) -> OutputSample {
        OutputSample {
            sensor_height_m: x[0],
            bellow_gauge_pa: self.stiffness_n_per_m * x[0] / Self::AREA_M2,
        }
    }
    fn initial_state(
        &self,
        _u: &InputSample,
        ic: &InitialCondition,
    ) -> Result<Vec<f64>, ModelError> {
        let x0 = match *ic {
            InitialCondition::SensorHeight { height_m } => height_m,
            InitialCondition::BellowPressure { gauge_pa } => {
                gauge_pa * Self::AREA_M2 / self.stiffness_n_per_m
            }
        };
        Ok(vec![x0, 0.0])
    }
}

/// Its parameters are its own fields.
impl NamedParameters for DampedOscillator {
    fn infos(&self) -> &[ParameterInfo] {
        Self::INFO
    }
    fn value(&self, name: &str) -> Result<f64, ModelError> {
        match name {
            "m" => Ok(self.mass_kg),
            "c" => Ok(self.damping_n_s_per_m),
            "k" => Ok(self.stiffness_n_per_m),
            _ => Err(unknown(self.name(), name, Self::INFO)),
        }
    }
    fn set_value(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
        match checked(self.name(), Self::INFO, name, value)? {
            0 => self.mass_kg = value,
            1 => self.damping_n_s_per_m = value,
            _ => self.stiffness_n_per_m = value,
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------

/// `tau y' = gain * wheel_load - y`: a first-order lag driven by the load (a step gives an
/// exponential). Outputs: `sensor_height_m = y`, `bellow_gauge_pa = wheel_load` (a direct
/// feed-through, so that tests see which sample's input the output map gets).
#[derive(Debug, Clone, PartialEq)]
pub struct FirstOrderLag {
    pub tau_s: f64,
    pub gain_m_per_kg: f64,
}

impl FirstOrderLag {
    const INFO: &'static [ParameterInfo] = &[
        param("tau", "s", "time constant", 1e-6, 1e6),
        param("gain", "m/kg", "static gain", -1e3, 1e3),
    ];

    /// The exact `y` at the sample times, inputs held, from `y0`.
    pub fn exact_response(&self, time_s: &[f64], loads: &[f64], y0: f64) -> Vec<f64> {
        let mut out = Vec::with_capacity(time_s.len());
        let mut y = y0;
        for k in 0..time_s.len() {
            if k > 0 {
                let target = self.gain_m_per_kg * loads[k - 1];
                y = target + (y - target) * (-(time_s[k] - time_s[k - 1]) / self.tau_s).exp();
            }
            out.push(y);
        }
        out
    }
}

impl SuspensionModel for FirstOrderLag {
    fn name(&self) -> &'static str {
        "ref-lag"
    }
    fn description(&self) -> &'static str {
        "reference: first-order lag driven by the wheel load (analytic solution)"
    }
    fn states(&self) -> &[StateInfo] {
        const STATES: &[StateInfo] = &[StateInfo::new("y_m", "m", StateRole::Position)];
        STATES
    }
    fn parameters(&self) -> &dyn NamedParameters {
        self
    }
    fn parameters_mut(&mut self) -> &mut dyn NamedParameters {
        self
    }
    fn rhs(&self, _t: f64, x: &[f64], u: &InputSample, dx: &mut [f64]) {
        dx[0] = (self.gain_m_per_kg * u.wheel_load_kg - x[0]) / self.tau_s;
    }
    fn output(&self, x: &[f64], u: &InputSample) -> OutputSample {
        OutputSample {
            sensor_height_m: x[0],
            bellow_gauge_pa: u.wheel_load_kg,
        }
    }
    fn initial_state(
        &self,
        u: &InputSample,
        ic: &InitialCondition,
    ) -> Result<Vec<f64>, ModelError> {
        let _ = ic;
        Ok(vec![self.gain_m_per_kg * u.wheel_load_kg])
    }
}

/// Its parameters are its own fields.
impl NamedParameters for FirstOrderLag {
    fn infos(&self) -> &[ParameterInfo] {
        Self::INFO
    }
    fn value(&self, name: &str) -> Result<f64, ModelError> {
        match name {
            "tau" => Ok(self.tau_s),
            "gain" => Ok(self.gain_m_per_kg),
            _ => Err(unknown(self.name(), name, Self::INFO)),
        }
    }
    fn set_value(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
        match checked(self.name(), Self::INFO, name, value)? {
            0 => self.tau_s = value,
            _ => self.gain_m_per_kg = value,
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------

/// A rigid vessel of air filled and exhausted through the 3-state valve (SPEC §2, eq 3.17–3.19
/// with constant volume): `p = n R T / V`, `n' = (p_supply - p) / R1` (fill),
/// `-(p - p_amb) / R2` (exhaust), `0` (closed). Linear in `n`, so the exact answer is an
/// exponential per segment. Outputs: `bellow_gauge_pa = p - p_amb`, `sensor_height_m = 0`.
#[derive(Debug, Clone, PartialEq)]
pub struct GasVolume {
    pub volume_m3: f64,
    pub temperature_k: f64,
    pub fill_resistance: f64,
    pub exhaust_resistance: f64,
    /// Ambient (exhaust side) absolute pressure, Pa.
    pub ambient_pa: f64,
}

impl GasVolume {
    pub const R: f64 = 8.314462618;
    const INFO: &'static [ParameterInfo] = &[
        param("volume", "m^3", "vessel volume", 1e-6, 10.0),
        param("rflow1", "Pa s/mol", "fill resistance", 1.0, 1e12),
        param("rflow2", "Pa s/mol", "exhaust resistance", 1.0, 1e12),
    ];

    pub fn reference() -> Self {
        Self {
            volume_m3: 0.02,
            temperature_k: 293.15,
            fill_resistance: 2.5e6,
            exhaust_resistance: 1.5e6,
            ambient_pa: 101_325.0,
        }
    }

    fn pressure(&self, n: f64) -> f64 {
        n * Self::R * self.temperature_k / self.volume_m3
    }

    /// The exact gauge pressure at the sample times, inputs held, from gauge `p0`.
    pub fn exact_response(
        &self,
        time_s: &[f64],
        valve: &[ValveState],
        supply_gauge_pa: &[f64],
        p0: f64,
    ) -> Vec<f64> {
        let c = Self::R * self.temperature_k / self.volume_m3;
        let mut out = Vec::with_capacity(time_s.len());
        let mut p = p0 + self.ambient_pa;
        for k in 0..time_s.len() {
            if k > 0 {
                let dt = time_s[k] - time_s[k - 1];
                let (target, rate) = match valve[k - 1] {
                    ValveState::Closed => (p, 0.0),
                    ValveState::Fill => (
                        supply_gauge_pa[k - 1] + self.ambient_pa,
                        c / self.fill_resistance,
                    ),
                    ValveState::Exhaust => (self.ambient_pa, c / self.exhaust_resistance),
                };
                p = target + (p - target) * (-rate * dt).exp();
            }
            out.push(p - self.ambient_pa);
        }
        out
    }
}

impl SuspensionModel for GasVolume {
    fn name(&self) -> &'static str {
        "ref-gas"
    }
    fn description(&self) -> &'static str {
        "reference: rigid air vessel behind the 3-state valve (analytic solution)"
    }
    fn states(&self) -> &[StateInfo] {
        const STATES: &[StateInfo] = &[StateInfo::new("n_mol", "mol", StateRole::BellowAir)];
        STATES
    }
    fn parameters(&self) -> &dyn NamedParameters {
        self
    }
    fn parameters_mut(&mut self) -> &mut dyn NamedParameters {
        self
    }
    fn rhs(&self, _t: f64, x: &[f64], u: &InputSample, dx: &mut [f64]) {
        let p = self.pressure(x[0]);
        dx[0] = match u.valve {
            ValveState::Closed => 0.0,
            ValveState::Fill => (u.supply_gauge_pa + self.ambient_pa - p) / self.fill_resistance,
            ValveState::Exhaust => -(p - self.ambient_pa) / self.exhaust_resistance,
        };
    }
    fn output(&self, x: &[f64], _u: &InputSample) -> OutputSample {
        OutputSample {
            sensor_height_m: 0.0,
            bellow_gauge_pa: self.pressure(x[0]) - self.ambient_pa,
        }
    }
    fn initial_state(
        &self,
        _u: &InputSample,
        ic: &InitialCondition,
    ) -> Result<Vec<f64>, ModelError> {
        match *ic {
            InitialCondition::BellowPressure { gauge_pa } => Ok(vec![
                (gauge_pa + self.ambient_pa) * self.volume_m3 / (Self::R * self.temperature_k),
            ]),
            InitialCondition::SensorHeight { .. } => Err(ModelError::NoEquilibrium {
                model: self.name().to_owned(),
                what: "a sensor height".to_owned(),
                reason: "a rigid vessel has no height".to_owned(),
            }),
        }
    }
}

/// Its parameters are its own fields.
impl NamedParameters for GasVolume {
    fn infos(&self) -> &[ParameterInfo] {
        Self::INFO
    }
    fn value(&self, name: &str) -> Result<f64, ModelError> {
        match name {
            "volume" => Ok(self.volume_m3),
            "rflow1" => Ok(self.fill_resistance),
            "rflow2" => Ok(self.exhaust_resistance),
            _ => Err(unknown(self.name(), name, Self::INFO)),
        }
    }
    fn set_value(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
        match checked(self.name(), Self::INFO, name, value)? {
            0 => self.volume_m3 = value,
            1 => self.fill_resistance = value,
            _ => self.exhaust_resistance = value,
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------

/// A model that goes wrong on purpose: air leaks at a constant rate (`n' = -leak`, so `n`
/// reaches zero at `n0 / leak`) and `x' = a x` explodes for `a > 0`.
#[derive(Debug, Clone, PartialEq)]
pub struct Runaway {
    pub leak_mol_per_s: f64,
    pub growth_per_s: f64,
    pub n0_mol: f64,
    pub x0_m: f64,
}

impl Runaway {
    const INFO: &'static [ParameterInfo] = &[
        param("leak", "mol/s", "constant leak", -1e6, 1e6),
        param("a", "1/s", "growth rate", -1e6, 1e6),
    ];
}

impl SuspensionModel for Runaway {
    fn name(&self) -> &'static str {
        "ref-runaway"
    }
    fn description(&self) -> &'static str {
        "reference: a leaking vessel and an exploding state (failure tests)"
    }
    fn states(&self) -> &[StateInfo] {
        const STATES: &[StateInfo] = &[
            StateInfo::new("n_mol", "mol", StateRole::BellowAir),
            StateInfo::new("x_m", "m", StateRole::Position),
        ];
        STATES
    }
    fn parameters(&self) -> &dyn NamedParameters {
        self
    }
    fn parameters_mut(&mut self) -> &mut dyn NamedParameters {
        self
    }
    fn rhs(&self, _t: f64, x: &[f64], _u: &InputSample, dx: &mut [f64]) {
        dx[0] = -self.leak_mol_per_s;
        dx[1] = self.growth_per_s * x[1];
    }
    fn output(&self, x: &[f64], _u: &InputSample) -> OutputSample {
        OutputSample {
            sensor_height_m: x[1],
            bellow_gauge_pa: x[0],
        }
    }
    fn initial_state(
        &self,
        _u: &InputSample,
        _ic: &InitialCondition,
    ) -> Result<Vec<f64>, ModelError> {
        Ok(vec![self.n0_mol, self.x0_m])
    }
}

/// Its parameters are its own fields.
impl NamedParameters for Runaway {
    fn infos(&self) -> &[ParameterInfo] {
        Self::INFO
    }
    fn value(&self, name: &str) -> Result<f64, ModelError> {
        match name {
            "leak" => Ok(self.leak_mol_per_s),
            "a" => Ok(self.growth_per_s),
            _ => Err(unknown(self.name(), name, Self::INFO)),
        }
    }
    fn set_value(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
        match checked(self.name(), Self::INFO, name, value)? {
            0 => self.leak_mol_per_s = value,
            _ => self.growth_per_s = value,
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------

/// A two-mass quarter car with an isothermal gas bellow, a linear damper and a tire that
/// cannot pull (lift-off): the stiffness structure of the thesis models without their
/// geometry. No analytic solution; it stands in for Model 1 in benchmarks until the real models
/// exist, and tests that the solver copes with contact loss.
///
/// States: chassis height `x1`, axle height `x2` (both above the road datum, m), their
/// velocities, and the amount of air `n`. Bellow height `h = x1 - x2`;
/// `p = n R T / (A_g h)`; force `(p - p_amb) A_eff(h)`, `A_eff = a0 + a1 (h - 0.3)`;
/// tire force `k_w max(0, r_w + z_r - x2)`; sprung mass `m_tot - m2`.
#[derive(Debug, Clone, PartialEq)]
pub struct ToyQuarterCar {
    pub unsprung_kg: f64,
    pub tire_n_per_m: f64,
    pub tire_radius_m: f64,
    pub damping_n_s_per_m: f64,
    pub area0_m2: f64,
    pub area1_m: f64,
    pub gas_area_m2: f64,
    pub temperature_k: f64,
    pub ambient_pa: f64,
    pub fill_resistance: f64,
    pub exhaust_resistance: f64,
}

impl ToyQuarterCar {
    const H_NOM: f64 = 0.3;
    const INFO: &'static [ParameterInfo] = &[
        param("m2", "kg", "unsprung mass", 1.0, 5000.0),
        param("kw", "N/m", "tire stiffness", 1e3, 1e8),
        param("c", "N s/m", "damping", 0.0, 1e6),
    ];

    pub fn reference() -> Self {
        Self {
            unsprung_kg: 520.0,
            tire_n_per_m: 1.8e6,
            tire_radius_m: 0.5,
            damping_n_s_per_m: 12_000.0,
            area0_m2: 0.08,
            area1_m: -0.05,
            gas_area_m2: 0.05,
            temperature_k: 293.15,
            ambient_pa: 101_325.0,
            fill_resistance: 2.5e6,
            exhaust_resistance: 1.5e6,
        }
    }

    fn effective_area(&self, h: f64) -> f64 {
        self.area0_m2 + self.area1_m * (h - Self::H_NOM)
    }

    fn pressure(&self, n: f64, h: f64) -> f64 {
        n * GasVolume::R * self.temperature_k / (self.gas_area_m2 * h)
    }
}

impl SuspensionModel for ToyQuarterCar {
    fn name(&self) -> &'static str {
        "ref-quarter-car"
    }
    fn description(&self) -> &'static str {
        "reference: two-mass quarter car with gas bellow and lift-off tire (benchmark stand-in)"
    }
    fn states(&self) -> &[StateInfo] {
        const STATES: &[StateInfo] = &[
            StateInfo::new("x1_m", "m", StateRole::Position),
            StateInfo::new("x2_m", "m", StateRole::Position),
            StateInfo::new("v1_m_s", "m/s", StateRole::Velocity),
            StateInfo::new("v2_m_s", "m/s", StateRole::Velocity),
            StateInfo::new("n_mol", "mol", StateRole::BellowAir),
        ];
        STATES
    }
    fn parameters(&self) -> &dyn NamedParameters {
        self
    }
    fn parameters_mut(&mut self) -> &mut dyn NamedParameters {
        self
    }
    fn rhs(&self, _t: f64, x: &[f64], u: &InputSample, dx: &mut [f64]) {
        let (x1, x2, v1, v2, n) = (x[0], x[1], x[2], x[3], x[4]);
        let m1 = u.wheel_load_kg - self.unsprung_kg;
        let h = x1 - x2;
        let p = self.pressure(n, h);
        let f_bellow = (p - self.ambient_pa) * self.effective_area(h);
        let f_damper = self.damping_n_s_per_m * (v1 - v2);
        let f_tire = self.tire_n_per_m * (self.tire_radius_m + u.road_height_m - x2).max(0.0);
        dx[0] = v1;
        dx[1] = v2;
        dx[2] = (f_bellow - f_damper) / m1 - G;
        dx[3] = (f_damper - f_bellow + f_tire) / self.unsprung_kg - G;
        dx[4] = match u.valve {
            ValveState::Closed => 0.0,
            ValveState::Fill => (u.supply_gauge_pa + self.ambient_pa - p) / self.fill_resistance,
            ValveState::Exhaust => -(p - self.ambient_pa) / self.exhaust_resistance,
        };
    }
    fn output(&self, x: &[f64], _u: &InputSample) -> OutputSample {
        let h = x[0] - x[1];
        OutputSample {
            sensor_height_m: h,
            bellow_gauge_pa: self.pressure(x[4], h) - self.ambient_pa,
        }
    }
    fn initial_state(
        &self,
        u: &InputSample,
        ic: &InitialCondition,
    ) -> Result<Vec<f64>, ModelError> {
        let m1 = u.wheel_load_kg - self.unsprung_kg;
        let no = |reason: String| ModelError::NoEquilibrium {
            model: self.name().to_owned(),
            what: format!("wheel load {} kg", u.wheel_load_kg),
            reason,
        };
        if m1 <= 0.0 {
            return Err(no("the load does not exceed the unsprung mass".to_owned()));
        }
        let force = m1 * G;
        // p_gauge * (a0 + a1 (h - h_nom)) = force
        let (h, p_gauge) = match *ic {
            InitialCondition::SensorHeight { height_m } => {
                (height_m, force / self.effective_area(height_m))
            }
            InitialCondition::BellowPressure { gauge_pa } => (
                Self::H_NOM + (force / gauge_pa - self.area0_m2) / self.area1_m,
                gauge_pa,
            ),
        };
        if !(h > 0.0 && p_gauge > -self.ambient_pa && self.effective_area(h) > 0.0) {
            return Err(no(format!(
                "bellow height {h} m, gauge pressure {p_gauge} Pa"
            )));
        }
        let x2 = self.tire_radius_m + u.road_height_m - u.wheel_load_kg * G / self.tire_n_per_m;
        let n = (p_gauge + self.ambient_pa) * self.gas_area_m2 * h
            / (GasVolume::R * self.temperature_k);
        Ok(vec![x2 + h, x2, 0.0, 0.0, n])
    }
}

/// Its parameters are its own fields.
impl NamedParameters for ToyQuarterCar {
    fn infos(&self) -> &[ParameterInfo] {
        Self::INFO
    }
    fn value(&self, name: &str) -> Result<f64, ModelError> {
        match name {
            "m2" => Ok(self.unsprung_kg),
            "kw" => Ok(self.tire_n_per_m),
            "c" => Ok(self.damping_n_s_per_m),
            _ => Err(unknown(self.name(), name, Self::INFO)),
        }
    }
    fn set_value(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
        match checked(self.name(), Self::INFO, name, value)? {
            0 => self.unsprung_kg = value,
            1 => self.tire_n_per_m = value,
            _ => self.damping_n_s_per_m = value,
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------

/// The benchmark scenario (thesis data-sets 1–2 style): `duration_s` at `dt_s` sampling, valve
/// closed, supply 850 kPa with a deterministic ±1 kPa logging noise (so that the restart
/// policy is exercised), wheel load `base_kg` with `step_kg` added and removed alternately
/// every `period_s` (up, up, down, down, …: one then two steps on).
pub fn load_step_run(duration_s: f64, dt_s: f64, base_kg: f64, step_kg: f64, period_s: f64) -> Run {
    let n = (duration_s / dt_s).round() as usize + 1;
    let time_s: Vec<f64> = (0..n).map(|k| k as f64 * dt_s).collect();
    let pattern = [0.0, 1.0, 2.0, 1.0];
    let wheel_load_kg = time_s
        .iter()
        .map(|t| base_kg + step_kg * pattern[(t / period_s).floor() as usize % pattern.len()])
        .collect();
    let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
    let supply_gauge_pa = (0..n)
        .map(|_| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            850_000.0 + ((seed % 21) as f64 - 10.0) * 100.0
        })
        .collect();
    Run {
        name: "load-steps".to_owned(),
        time_s,
        sample_time_s: dt_s,
        inputs: RunInputs {
            wheel_load_kg,
            valve: vec![ValveState::Closed; n],
            supply_gauge_pa,
            road_height_m: vec![0.0; n],
        },
        outputs: None,
    }
}
