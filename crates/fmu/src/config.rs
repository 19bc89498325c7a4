//! What an FMU carries besides its binary: `resources/airsus.toml` ([`ExportConfig`]) and what
//! both the exporter and the library derive from it ([`Prepared`]: the model with its
//! parameters, the variables, `modelDescription.xml` and the GUID).
//!
//! The resources file holds the model's name, the whole truck file (as `truck_to_toml` writes
//! it: every key, the values the model was built from), every parameter value of the model by
//! its registry name, and the initial height. The library rebuilds the model from it exactly
//! as `airsus simulate --model M --truck T.toml` does, then applies the parameter values (for
//! the `truck` model these also carry its own effect parameters, which a truck file has no key
//! for).

use std::path::Path;

use airsus_data::TruckParameters;
use airsus_model::{ModelError, SuspensionModel};
use airsus_truck::models::build_any_model;
use serde::Deserialize;

use crate::description::{self, Feedthrough, GUID_PLACEHOLDER, Variable};

/// The file under `resources/` that the library reads at `fmi2Instantiate`.
pub const RESOURCE_FILE: &str = "airsus.toml";

/// Version of the resources file's layout (see also [`crate::LAYOUT_VERSION`]).
pub const CONFIG_FORMAT: u32 = 1;

/// The sensor height the FMU starts from unless told otherwise, mm: the reference truck's ride
/// height (SPEC §5), the default target of `airsus control` and start of `airsus road`.
pub const DEFAULT_INITIAL_HEIGHT_MM: f64 = 240.0;

#[derive(Debug, thiserror::Error)]
pub enum FmuError {
    /// The resources file or an argument is not what an FMU can be built from.
    #[error("{0}")]
    Config(String),
    /// The truck file inside the resources does not load (boxed: keeps `Result`s small).
    #[error(transparent)]
    Data(Box<airsus_data::DataError>),
    /// The model rejects the name or a parameter value.
    #[error(transparent)]
    Model(Box<ModelError>),
    #[error("writing {path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
}

impl From<airsus_data::DataError> for FmuError {
    fn from(e: airsus_data::DataError) -> Self {
        Self::Data(Box::new(e))
    }
}

impl From<ModelError> for FmuError {
    fn from(e: ModelError) -> Self {
        Self::Model(Box::new(e))
    }
}

/// One parameter value by its registry name.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterValue {
    pub name: String,
    pub value: f64,
}

/// The content of `resources/airsus.toml`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExportConfig {
    /// [`CONFIG_FORMAT`] of the writer.
    pub format: u32,
    /// The airsus version that exported the FMU (informational).
    pub airsus_version: String,
    /// Registry name: `m1`, `m2`, `m2x`, `m2xh`, `m3` or `truck`.
    pub model: String,
    /// Start value of the `initial_height_mm` parameter.
    pub initial_height_mm: f64,
    /// The truck file's text.
    pub truck: String,
    /// Every parameter of the model with its value, in registry order.
    #[serde(default)]
    pub parameter: Vec<ParameterValue>,
}

impl ExportConfig {
    /// The configuration exporting `model` built from `truck`, starting at `initial_height_mm`.
    pub fn new(
        model: &str,
        truck: &TruckParameters,
        initial_height_mm: f64,
    ) -> Result<Self, FmuError> {
        let built = build_any_model(model, truck)?;
        let parameter = built
            .parameter_info()
            .iter()
            .map(|info| {
                Ok(ParameterValue {
                    name: info.name.to_owned(),
                    value: built.parameter(info.name)?,
                })
            })
            .collect::<Result<Vec<_>, ModelError>>()?;
        Ok(Self {
            format: CONFIG_FORMAT,
            airsus_version: env!("CARGO_PKG_VERSION").to_owned(),
            model: model.to_owned(),
            initial_height_mm,
            truck: airsus_data::truck_to_toml(truck),
            parameter,
        })
    }

    /// Parses the resources file.
    pub fn from_toml(text: &str) -> Result<Self, FmuError> {
        toml::from_str(text)
            .map_err(|e: toml::de::Error| FmuError::Config(format!("{RESOURCE_FILE}: {e}")))
    }

    /// The resources file. Deterministic, and [`Self::from_toml`] reads back identical values
    /// (floats in shortest round-trip form), so the GUID computed from it at export and at
    /// instantiation agree.
    pub fn to_toml(&self) -> String {
        let quote = |s: &str| toml::Value::String(s.to_owned()).to_string();
        let mut s = String::new();
        s.push_str("# airsus FMU resources, read by the FMU's library at fmi2Instantiate.\n");
        s.push_str("# The FMU's GUID covers this file: change parameters through the FMU's\n");
        s.push_str("# variables (start values), not here; re-export with `airsus fmu` instead.\n");
        s.push_str(&format!("format = {}\n", self.format));
        s.push_str(&format!(
            "airsus_version = {}\n",
            quote(&self.airsus_version)
        ));
        s.push_str(&format!("model = {}\n", quote(&self.model)));
        s.push_str(&format!(
            "initial_height_mm = {:?}\n",
            self.initial_height_mm
        ));
        s.push_str(&format!("truck = {}\n", quote(&self.truck)));
        for p in &self.parameter {
            s.push_str("\n[[parameter]]\n");
            s.push_str(&format!("name = {}\n", quote(&p.name)));
            s.push_str(&format!("value = {:?}\n", p.value));
        }
        s
    }
}

/// An export configuration made concrete: the model with its parameter values applied, the
/// FMU's variables, `modelDescription.xml` and the GUID. The exporter writes these; the library
/// recomputes them at `fmi2Instantiate` and compares the GUID with the host's.
#[derive(Debug, Clone)]
pub struct Prepared {
    pub config: ExportConfig,
    /// The model as the FMU starts it (every `fmi2Reset` returns to this).
    pub model: Box<dyn SuspensionModel>,
    pub variables: Vec<Variable>,
    pub feedthrough: Feedthrough,
    /// `{…}`: a fingerprint of `modelDescription.xml` (with the GUID left blank) and of the
    /// resources file.
    pub guid: String,
    pub model_description: String,
    /// Things the exporter should tell the user (e.g. a parameter outside its registry bounds).
    pub warnings: Vec<String>,
}

impl Prepared {
    pub fn new(config: ExportConfig) -> Result<Self, FmuError> {
        if config.format != CONFIG_FORMAT {
            return Err(FmuError::Config(format!(
                "{RESOURCE_FILE} has format {}, this library reads format {CONFIG_FORMAT}: export the FMU again with the airsus version of this library ({})",
                config.format,
                env!("CARGO_PKG_VERSION")
            )));
        }
        if !(config.initial_height_mm.is_finite() && config.initial_height_mm > 0.0) {
            return Err(FmuError::Config(format!(
                "initial height {} mm must be a positive number of millimetres",
                config.initial_height_mm
            )));
        }
        let loaded = airsus_data::truck::parse_truck(
            &config.truck,
            Path::new("resources/airsus.toml (truck)"),
        )?;
        let mut model = build_any_model(&config.model, &loaded.parameters)?;
        for p in &config.parameter {
            if !p.value.is_finite() {
                return Err(FmuError::Config(format!(
                    "parameter `{}` of model {} has no finite value ({}): give it in the truck file",
                    p.name, config.model, p.value
                )));
            }
            // Skip what the truck file already set: a value from a truck file may lie outside
            // the registry's (estimator's) bounds, which `set_parameter` would refuse.
            if model.parameter(&p.name)?.to_bits() != p.value.to_bits() {
                model.set_parameter(&p.name, p.value)?;
            }
        }
        let mut warnings = Vec::new();
        for info in model.parameter_info() {
            let value = model.parameter(info.name)?;
            if !value.is_finite() {
                return Err(FmuError::Config(format!(
                    "parameter `{}` of model {} has no finite value ({value}): give it in the truck file",
                    info.name, config.model
                )));
            }
            if !(info.lower..=info.upper).contains(&value) {
                warnings.push(format!(
                    "parameter `{}` = {value} {} lies outside its registry range {} to {}: the FMU declares no min/max for it, and a host can set it only inside the range",
                    info.name, info.unit, info.lower, info.upper
                ));
            }
        }
        let variables = description::variables(&*model, config.initial_height_mm);
        let feedthrough = description::feedthrough(&*model, config.initial_height_mm);
        let blank = description::model_description(
            &*model,
            &config,
            &variables,
            &feedthrough,
            GUID_PLACEHOLDER,
        );
        let resources = config.to_toml();
        let guid = crate::hash::guid(&[
            crate::BUILD_MARKER.as_bytes(),
            blank.as_bytes(),
            resources.as_bytes(),
        ]);
        let model_description = blank.replacen(GUID_PLACEHOLDER, &guid, 1);
        Ok(Self {
            config,
            model,
            variables,
            feedthrough,
            guid,
            model_description,
            warnings,
        })
    }

    /// The variable with this value reference and type.
    pub fn variable(&self, var_type: description::VarType, vr: u32) -> Option<&Variable> {
        self.variables
            .iter()
            .find(|v| v.var_type == var_type && v.value_reference == vr)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reference(model: &str) -> ExportConfig {
        ExportConfig::new(
            model,
            &TruckParameters::reference(),
            DEFAULT_INITIAL_HEIGHT_MM,
        )
        .unwrap()
    }

    #[test]
    fn the_resources_file_reads_back_identically() {
        for (model, _) in airsus_truck::models::all_model_names() {
            let config = match ExportConfig::new(
                model,
                &TruckParameters::reference(),
                DEFAULT_INITIAL_HEIGHT_MM,
            ) {
                Ok(c) => c,
                Err(e) => panic!("{model}: {e}"),
            };
            let text = config.to_toml();
            let back = ExportConfig::from_toml(&text).unwrap();
            assert_eq!(back, config, "{model}");
            assert_eq!(back.to_toml(), text, "{model}");
        }
    }

    #[test]
    fn export_and_instantiation_agree_on_the_guid() {
        let config = reference("m2");
        let exported = Prepared::new(config.clone()).unwrap();
        let reread = Prepared::new(ExportConfig::from_toml(&config.to_toml()).unwrap()).unwrap();
        assert_eq!(exported.guid, reread.guid);
        assert_eq!(exported.model_description, reread.model_description);
        assert!(exported.model_description.contains(&exported.guid));
        assert!(!exported.model_description.contains(GUID_PLACEHOLDER));
        let mut other = config;
        other.initial_height_mm = 250.0;
        assert_ne!(Prepared::new(other).unwrap().guid, exported.guid);
    }

    #[test]
    fn parameter_values_in_the_resources_override_the_truck_file() {
        let mut config = reference("m2");
        let kw = config
            .parameter
            .iter_mut()
            .find(|p| p.name == "kw")
            .unwrap();
        kw.value = 2.2e6;
        let prepared = Prepared::new(config).unwrap();
        assert_eq!(prepared.model.parameter("kw").unwrap(), 2.2e6);
        let start = prepared
            .variables
            .iter()
            .find(|v| v.name == "kw")
            .and_then(|v| v.start);
        assert_eq!(start, Some(2.2e6));
    }

    #[test]
    fn bad_resources_are_errors_not_panics() {
        assert!(ExportConfig::from_toml("model = 3").is_err());
        let mut config = reference("m1");
        config.format = 99;
        assert!(Prepared::new(config).is_err());
        let mut config = reference("m1");
        config.model = "m9".to_owned();
        assert!(Prepared::new(config).is_err());
        let mut config = reference("m1");
        config.truck = "[environment]\n".to_owned();
        assert!(Prepared::new(config).is_err());
        let mut config = reference("m1");
        config.initial_height_mm = f64::NAN;
        assert!(Prepared::new(config).is_err());
        let mut config = reference("m1");
        config.parameter.push(ParameterValue {
            name: "nonsense".to_owned(),
            value: 1.0,
        });
        assert!(Prepared::new(config).is_err());
    }

    #[test]
    fn the_build_marker_names_the_layout() {
        assert!(
            crate::BUILD_MARKER.ends_with(&format!(":layout-{};", crate::LAYOUT_VERSION)),
            "{}",
            crate::BUILD_MARKER
        );
    }
}
