//! The per-truck work of the fleet jobs (`airsus.fleet`, `python -m airsus.spark`): weighing at
//! the standstills of a truck's log (`airsus_apps::weigh::standstill`). The Python side
//! calibrates and looks for leaks with numpy on what this returns.

use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use airsus_apps::weigh::{
    StandstillDetector, StandstillSignals, StaticLaw, StaticWeigher, WeighingUncertainty,
    weigh_standstills,
};
use airsus_data::ValveState;

use crate::error::{AirsusError, OrPy};
use crate::truck::NativeTruck;

/// The standstills of one log, weighed with the truck's static law (`segment`: a change of
/// its value ends a standstill): a dict of equal-length
/// float64 arrays `first, last` (sample indices), `start_s, end_s, height_mm, pressure_kpa`
/// (means), `static_load_kg, measurement_std_kg, parameter_std_kg, friction_state`.
#[pyfunction]
#[pyo3(signature = (truck, time_s, height_mm, pressure_kpa, valve, speed_kmh=None, segment=None, settle_s=120.0, min_duration_s=20.0))]
#[allow(clippy::too_many_arguments)]
pub fn standstills<'py>(
    py: Python<'py>,
    truck: &NativeTruck,
    time_s: PyReadonlyArray1<'py, f64>,
    height_mm: PyReadonlyArray1<'py, f64>,
    pressure_kpa: PyReadonlyArray1<'py, f64>,
    valve: PyReadonlyArray1<'py, f64>,
    speed_kmh: Option<PyReadonlyArray1<'py, f64>>,
    segment: Option<PyReadonlyArray1<'py, f64>>,
    settle_s: f64,
    min_duration_s: f64,
) -> PyResult<Bound<'py, PyDict>> {
    if !(settle_s.is_finite() && settle_s >= 0.0 && min_duration_s.is_finite()) {
        return Err(AirsusError::new_err(
            "settle_s and min_duration_s must be finite, settle_s non-negative",
        ));
    }
    let valve: Vec<ValveState> = valve
        .as_slice()?
        .iter()
        .enumerate()
        .map(|(k, &code)| {
            ValveState::from_code(code).ok_or_else(|| {
                AirsusError::new_err(format!(
                    "valve at row {k} is {code}; expected 0 (closed), 1 (fill) or 2 (exhaust)"
                ))
            })
        })
        .collect::<PyResult<_>>()?;
    let height_m: Vec<f64> = height_mm.as_slice()?.iter().map(|h| h * 1e-3).collect();
    let gauge_pa: Vec<f64> = pressure_kpa.as_slice()?.iter().map(|p| p * 1e3).collect();
    let time = time_s.as_slice()?.to_vec();
    let optional = |a: &Option<PyReadonlyArray1<'py, f64>>| -> PyResult<Vec<f64>> {
        Ok(match a {
            Some(a) => a.as_slice()?.to_vec(),
            None => Vec::new(),
        })
    };
    let (speed, segment) = (optional(&speed_kmh)?, optional(&segment)?);
    // The gas alone, whatever the file's wall: a standstill is read 120 s after the valve
    // and 60 s steady, when the creep has relaxed, and the fleet's calibration regresses the
    // friction's state itself (a wall here would count it twice).
    let weigher = StaticWeigher::new(
        StaticLaw::from_truck(&truck.params).without_wall(),
        WeighingUncertainty::default(),
    );
    let detector = StandstillDetector {
        settle_s,
        min_duration_s,
        ..StandstillDetector::default()
    };
    let found = py
        .detach(|| {
            let signals = StandstillSignals {
                time_s: &time,
                height_m: &height_m,
                gauge_pa: &gauge_pa,
                valve: &valve,
                speed_kmh: &speed,
                segment: &segment,
            };
            // anyhow's error is one pointer: AppError is large to move across the closure.
            weigh_standstills(&signals, &weigher, &detector).map_err(anyhow::Error::from)
        })
        .or_py()?;
    type Field = fn(&airsus_apps::weigh::Standstill) -> f64;
    let fields: [(&str, Field); 10] = [
        ("first", |s| s.first as f64),
        ("last", |s| s.last as f64),
        ("start_s", |s| s.start_s),
        ("end_s", |s| s.end_s),
        ("height_mm", |s| s.height_m * 1e3),
        ("pressure_kpa", |s| s.gauge_pa * 1e-3),
        ("static_load_kg", |s| s.static_load_kg),
        ("measurement_std_kg", |s| s.measurement_std_kg),
        ("parameter_std_kg", |s| s.parameter_std_kg),
        ("friction_state", |s| s.friction_state),
    ];
    let dict = PyDict::new(py);
    for (name, field) in fields {
        let column: Vec<f64> = found.iter().map(field).collect();
        dict.set_item(name, column.into_pyarray(py))?;
    }
    Ok(dict)
}

/// The air in the bellow circuit, mol, for each (sensor height, bellow pressure, gas
/// temperature): `n = p_abs V(h_b) / (R T)` (thesis eq 3.17/3.18) with the bellow height from
/// the sensor through the static law (the lever's flex under the load the reading carries) and
/// the truck's gas-volume law. NaN where the reading carries no static load. The leak finder
/// compares this over a parked stretch: it stays constant in a tight circuit whatever the
/// temperature does.
#[pyfunction]
pub fn gas_amount_mol<'py>(
    py: Python<'py>,
    truck: &NativeTruck,
    height_mm: PyReadonlyArray1<'py, f64>,
    pressure_kpa: PyReadonlyArray1<'py, f64>,
    temperature_k: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, numpy::PyArray1<f64>>> {
    let (h, p, t) = (
        height_mm.as_slice()?,
        pressure_kpa.as_slice()?,
        temperature_k.as_slice()?,
    );
    if h.len() != p.len() || h.len() != t.len() {
        return Err(AirsusError::new_err(
            "height, pressure and temperature differ in length",
        ));
    }
    let params = &truck.params;
    let law = StaticLaw::from_truck(params);
    let env = &params.environment;
    let amounts: Vec<f64> = h
        .iter()
        .zip(p)
        .zip(t)
        .map(|((&h_mm, &p_kpa), &t_k)| {
            let (sensor_m, gauge_pa) = (h_mm * 1e-3, p_kpa * 1e3);
            match law.wheel_load_kg(sensor_m, gauge_pa) {
                Ok(load) if t_k > 0.0 => {
                    let bellow_m = law.bellow_height_m(sensor_m, load);
                    let volume = params
                        .bellow
                        .gas_volume
                        .volume_m3(&params.bellow.effective_area, bellow_m);
                    (gauge_pa + env.ambient_pressure_pa) * volume / (env.gas_constant_j_mol_k * t_k)
                }
                _ => f64::NAN,
            }
        })
        .collect();
    Ok(amounts.into_pyarray(py))
}
