//! Truck parameters: a truck file in memory, addressed by the SPEC §5 short names.

use std::path::PathBuf;

use anyhow::bail;
use pyo3::prelude::*;

use airsus_data::error::nearest_name;
use airsus_data::truck::parse_truck;
use airsus_data::{TruckParameters, read_truck, truck_to_toml, write_truck};
use airsus_model::params::{self, CATALOG, Field, Param};

use crate::error::OrPy;

/// The SPEC §5 short names, fixed so that scripts keep working. `ksd` is the slow-force scale
/// of Model 2 extended (`slow_dynamics.force_scale_n_per_m`), its SPEC meaning.
pub const TRUCK_NAMES: [&str; 18] = [
    "p0", "p1", "p2", "p3", "p4", "a0", "a1", "m2", "ig", "kf", "kw", "kscl", "rflow1", "rflow2",
    "ksd", "vd", "dscl", "cw",
];

/// The catalogue entry of a SPEC short name (the first entry of that name: for `ksd`, the
/// slow-force scale, as `airsus_model::params::spec_field` resolves it).
fn lookup(name: &str) -> anyhow::Result<&'static Param> {
    if let Some(param) = CATALOG.iter().find(|p| p.info.name == name)
        && (TRUCK_NAMES.contains(&name) || matches!(param.field, Field::AreaKnot(_)))
    {
        return Ok(param);
    }
    let suggestion = nearest_name(name, TRUCK_NAMES.iter().copied())
        .map(|s| format!(" (did you mean `{s}`?)"))
        .unwrap_or_default();
    bail!(
        "the truck has no parameter `{name}`{suggestion}; its parameters are: {} (and s0, s1, .. for a spline effective area's knots)",
        TRUCK_NAMES.join(", ")
    )
}

/// One row of [`NativeTruck::table`]: `(name, unit, description, value, lower, upper)`.
type ParameterRow = (&'static str, &'static str, &'static str, f64, f64, f64);

/// A truck parameter file in memory (SI units inside, as `airsus_data::TruckParameters`).
#[pyclass(module = "airsus._native", name = "NativeTruck")]
#[derive(Debug, Clone)]
pub struct NativeTruck {
    pub params: TruckParameters,
    /// Keys the file left out, with the values used (`section.key`, value as in a file).
    pub defaulted: Vec<(String, String)>,
}

impl NativeTruck {
    pub fn new(params: TruckParameters) -> Self {
        Self {
            params,
            defaulted: Vec::new(),
        }
    }
}

#[pymethods]
impl NativeTruck {
    /// Reads and checks a truck file (`airsus_data::read_truck`, as every command does).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let loaded = py.detach(|| read_truck(&path)).or_py()?;
        Ok(Self {
            params: loaded.parameters,
            defaulted: loaded
                .defaulted
                .into_iter()
                .map(|d| (d.key, d.value))
                .collect(),
        })
    }

    /// Parses truck-file text; `name` names the source in errors.
    #[staticmethod]
    fn from_toml(text: String, name: String) -> PyResult<Self> {
        let loaded = parse_truck(&text, std::path::Path::new(&name)).or_py()?;
        Ok(Self {
            params: loaded.parameters,
            defaulted: loaded
                .defaulted
                .into_iter()
                .map(|d| (d.key, d.value))
                .collect(),
        })
    }

    /// The SPEC's reference truck (`airsus params --builtin`).
    #[staticmethod]
    fn builtin() -> Self {
        Self::new(TruckParameters::reference())
    }

    /// Writes the truck file atomically (`airsus_data::write_truck`).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let params = self.params.clone();
        py.detach(move || write_truck(&path, &params)).or_py()
    }

    /// The truck file's text, every value resolved (`airsus params`).
    fn to_toml(&self) -> String {
        truck_to_toml(&self.params)
    }

    /// A parameter's value by short name (SI units; NaN for `ksd` when the file has none).
    /// A parameter of a law the truck does not have (`rflow1` under the orifice valve law) is
    /// an error, not a NaN.
    fn get(&self, name: String) -> PyResult<f64> {
        let param = lookup(&name).or_py()?;
        let value = params::get(&self.params, param.field);
        if value.is_nan() && param.field.law_family().is_some() {
            return Err(crate::error::to_py(anyhow::anyhow!(
                "truck parameter `{name}` belongs to another law than this truck's (its valve law is `{}`, its effective-area law `{}`, its gas-volume law `{}`)",
                self.params.valve.tag(),
                self.params.bellow.effective_area.tag(),
                self.params.bellow.gas_volume.tag()
            )));
        }
        Ok(value)
    }

    /// Sets a parameter by short name; rejects values outside its admissible range.
    fn set(&mut self, name: String, value: f64) -> PyResult<()> {
        let param = lookup(&name).or_py()?;
        let info = &param.info;
        // `!(..)` so that NaN is rejected too.
        if !(value >= info.lower && value <= info.upper) {
            return Err(crate::error::to_py(anyhow::anyhow!(
                "truck parameter `{name}` = {value} is outside its admissible range {} to {} {}",
                info.lower,
                info.upper,
                info.unit
            )));
        }
        if !params::set(&mut self.params, param.field, value) {
            return Err(crate::error::to_py(anyhow::anyhow!(
                "truck parameter `{name}` belongs to another law than this truck's (its valve law is `{}`, its effective-area law `{}`, its gas-volume law `{}`)",
                self.params.valve.tag(),
                self.params.bellow.effective_area.tag(),
                self.params.bellow.gas_volume.tag()
            )));
        }
        Ok(())
    }

    /// The short names, in SPEC order.
    #[staticmethod]
    fn names() -> Vec<&'static str> {
        TRUCK_NAMES.to_vec()
    }

    /// One row per short name: `(name, unit, description, value, lower, upper)`; a spline
    /// effective area's knots (`s0`, ..) follow.
    fn table(&self) -> Vec<ParameterRow> {
        let knots: Vec<&'static str> = self
            .params
            .bellow
            .effective_area
            .fields()
            .into_iter()
            .filter(|f| matches!(f, Field::AreaKnot(_)))
            .map(|f| f.param().info.name)
            .collect();
        TRUCK_NAMES
            .iter()
            .chain(&knots)
            .filter_map(|name| lookup(name).ok())
            .map(|p| {
                (
                    p.info.name,
                    p.info.unit,
                    p.info.description,
                    params::get(&self.params, p.field),
                    p.info.lower,
                    p.info.upper,
                )
            })
            .collect()
    }

    /// Keys the file left out, with the values used: `[(key, value), ...]`.
    fn defaulted(&self) -> Vec<(String, String)> {
        self.defaulted.clone()
    }

    /// An independent copy.
    fn copy(&self) -> Self {
        self.clone()
    }

    /// Whether both hold the same parameters (every value equal).
    fn equals(&self, other: PyRef<'_, Self>) -> bool {
        self.params == other.params
    }
}
