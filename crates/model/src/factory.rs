//! Models by name (the command line's `--model`).

use airsus_data::TruckParameters;
use airsus_data::error::nearest_name;

use crate::m1::Model1;
use crate::m2::Model2;
use crate::m3::Model3;
use crate::model::{ModelError, SuspensionModel};

/// The names [`build_model`] accepts, with one line each.
pub const MODEL_NAMES: &[(&str, &str)] = &[
    (
        "m1",
        "Model 1: QCM 1, two vertical masses (thesis eq 3.4/4.1)",
    ),
    (
        "m2",
        "Model 2: QCM 2, chassis height and lever angle (thesis eq 3.6-3.13/4.2)",
    ),
    (
        "m2x",
        "Model 2 extended: + OE slow force from load change (thesis eq 4.3/4.4)",
    ),
    (
        "m2xh",
        "Model 2 + bellow creep force from height change (thesis 6.2)",
    ),
    (
        "m3",
        "Model 3: gas and valve physics + OE height model (thesis eq 4.5)",
    ),
];

/// Builds the model called `name` (`m1`, `m2`, `m2x`, `m2xh`, `m3`) with `truck`'s parameters.
/// Unknown names get a nearest-name suggestion.
pub fn build_model(
    name: &str,
    truck: &TruckParameters,
) -> Result<Box<dyn SuspensionModel>, ModelError> {
    Ok(match name {
        "m1" => Box::new(Model1::new(truck)),
        "m2" => Box::new(Model2::new(truck)),
        "m2x" => Box::new(Model2::extended(truck)?),
        "m2xh" => Box::new(Model2::height_creep(truck)),
        "m3" => Box::new(Model3::new(truck)?),
        _ => {
            return Err(ModelError::UnknownModel {
                name: name.to_owned(),
                suggestion: nearest_name(name, MODEL_NAMES.iter().map(|(n, _)| *n)),
                valid: MODEL_NAMES.iter().map(|(n, _)| (*n).to_owned()).collect(),
            });
        }
    })
}
