//! Every model airsus builds by name: the thesis models of `airsus-model` and the virtual
//! truck's structure `truck`, which lives here because it needs the truck's extra physics.

use airsus_data::TruckParameters;
use airsus_data::error::nearest_name;
use airsus_model::{MODEL_NAMES, ModelError, SuspensionModel, build_model};

use crate::model::TruckModel;

/// The `truck` structure's one-line description.
pub const TRUCK_MODEL: (&str, &str) = (
    "truck",
    "Virtual-truck structure: Model 2 + creep, wall friction, gas heat exchange, ISO 6358 valve, supply line",
);

/// All model names with their descriptions, in the order the report lists them.
pub fn all_model_names() -> Vec<(&'static str, &'static str)> {
    MODEL_NAMES.iter().copied().chain([TRUCK_MODEL]).collect()
}

/// Builds any model by name; `truck` starts from the file's nominal values with the extra
/// effects at their built-in defaults.
pub fn build_any_model(
    name: &str,
    truck: &TruckParameters,
) -> Result<Box<dyn SuspensionModel>, ModelError> {
    if name == TRUCK_MODEL.0 {
        return Ok(Box::new(TruckModel::from_truck_parameters(truck)));
    }
    build_model(name, truck).map_err(|err| match err {
        ModelError::UnknownModel { name, .. } => {
            let names = all_model_names();
            ModelError::UnknownModel {
                suggestion: nearest_name(&name, names.iter().map(|(n, _)| *n)),
                valid: names.iter().map(|(n, _)| (*n).to_owned()).collect(),
                name,
            }
        }
        other => other,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builds_every_named_model_and_suggests_for_typos() {
        let truck = TruckParameters::reference();
        for (name, _) in all_model_names() {
            assert_eq!(build_any_model(name, &truck).unwrap().name(), name);
        }
        let err = build_any_model("truk", &truck).unwrap_err().to_string();
        assert!(err.contains("truck"), "{err}");
    }
}
