//! The model registry: every model airsus builds by name — the thesis models of
//! `airsus-model` and the virtual truck's structure `truck`, which lives here because it needs
//! the truck's extra physics. Every command, the study, the FMU export, the Python package and
//! `airsus models` read this one list.

use airsus_data::TruckParameters;
use airsus_model::{
    Excitation, ModelEntry, ModelError, ParameterInfo, StateInfo, SuspensionModel, THESIS_MODELS,
    find_model,
};

use crate::model::TruckModel;

/// The `truck` structure: Model 2's lever with every effect of the virtual truck.
pub const TRUCK_MODEL: ModelEntry = ModelEntry {
    name: "truck",
    summary: "Virtual-truck structure: Model 2 + creep, wall friction, gas heat exchange, ISO 6358 valve, supply line",
    build: |truck| Ok(Box::new(TruckModel::from_truck_parameters(truck))),
    // Model 2's set plus the creep element and the wall friction's pre-sliding stiffness
    // (the force map measures the sliding force `fc`, not how soon the wall slides: held at
    // the built-in 20 kN/m, variant 2's 14.8 kN/m cost its held-out data-set 4 five points of
    // pressure; freed, variants 0-3 come out at 19.1, 20.1, 14.7 and 19.1 kN/m against 20.0,
    // 19.2, 14.8 and 19.5); with valve action the valve's flow coefficients (the conductances
    // under its orifice), the gas volume's scale and the gas's thermal time (a fill
    // compresses and heats the gas, which cools over `tth`: held at the built-in 20 s it
    // cost a variant drawn at 35.6 s 15 points of data-set 4's pressure); with road input
    // the damper table's scale. The study then holds the valve at the lab's values and frees
    // the volume's shape and the supply line in its place (`airsus_study`).
    default_free: &[
        "p0", "p1", "p2", "p3", "p4", "m2", "ig", "kc", "tc", "kdahl",
    ],
    valve_free: &["c1", "c2", "a0", "tth"],
    road_free: &["dscl", "kf"],
    // Freed jointly with the standing runs' set, the tire's stiffness came out 10-20 % low on
    // variants 0-2; refitted on the road run alone from the joint estimate, with the damper's
    // scale and the lever's inertia, within 0.2-4.5 % on variants 0-3 (the joint estimate had
    // taken variant 3's inertia 12 % low to make up for its 14 % stiffer tires).
    road_refit: &["dscl", "kw", "ig", "kf"],
    lab_laws: true,
    height_block_per_protocol: false,
};

/// Every registered model, in report order: the thesis models, then `truck`.
pub static MODELS: [ModelEntry; 6] = [
    THESIS_MODELS[0],
    THESIS_MODELS[1],
    THESIS_MODELS[2],
    THESIS_MODELS[3],
    THESIS_MODELS[4],
    TRUCK_MODEL,
];

/// The registered names, in report order.
pub fn model_names() -> Vec<&'static str> {
    MODELS.iter().map(|e| e.name).collect()
}

/// The registry entry called `name`; unknown names get a nearest-name suggestion.
pub fn model_entry(name: &str) -> Result<&'static ModelEntry, ModelError> {
    find_model(&MODELS, name)
}

/// All model names with their one-line descriptions, in report order.
pub fn all_model_names() -> Vec<(&'static str, &'static str)> {
    MODELS.iter().map(|e| (e.name, e.summary)).collect()
}

/// What a grey-box fit of `model` frees by default on `runs`: the registry's set, plus the
/// valve-action parameters (flow law, gas volume scale) when a run has valve action and the
/// road parameters when a run has road input, under the model's laws. The excitation says
/// which were added.
pub fn default_free(
    model: &dyn SuspensionModel,
    runs: &[&airsus_data::Run],
) -> Result<(Vec<&'static str>, Excitation), ModelError> {
    let excitation = Excitation::of(runs.iter().copied());
    Ok((
        model_entry(model.name())?.free_parameters(excitation, model),
        excitation,
    ))
}

/// Builds any registered model by name with `truck`'s parameters; `truck` starts from the
/// file's nominal values with the extra effects at their built-in defaults.
pub fn build_any_model(
    name: &str,
    truck: &TruckParameters,
) -> Result<Box<dyn SuspensionModel>, ModelError> {
    (model_entry(name)?.build)(truck)
}

/// What `airsus models` prints about one model: built with the reference truck, so each
/// parameter's `default` is the reference truck's value.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelDescription {
    pub name: &'static str,
    /// The model's own description (with its thesis source).
    pub description: &'static str,
    /// The registry's one-line summary.
    pub summary: &'static str,
    pub default_free: &'static [&'static str],
    pub valve_free: &'static [&'static str],
    pub road_free: &'static [&'static str],
    pub road_refit: &'static [&'static str],
    pub parameters: Vec<ParameterDescription>,
    pub states: Vec<StateInfo>,
}

/// One parameter of a [`ModelDescription`].
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterDescription {
    pub info: ParameterInfo,
    /// The value with the reference truck's parameters.
    pub default: f64,
}

/// Every registered model described, in report order.
pub fn describe_models() -> Result<Vec<ModelDescription>, ModelError> {
    let truck = TruckParameters::reference();
    MODELS
        .iter()
        .map(|entry| {
            let model = (entry.build)(&truck)?;
            let parameters = model
                .parameter_info()
                .iter()
                .map(|info| {
                    Ok(ParameterDescription {
                        info: info.clone(),
                        default: model.parameter(info.name)?,
                    })
                })
                .collect::<Result<Vec<_>, ModelError>>()?;
            Ok(ModelDescription {
                name: entry.name,
                description: model.description(),
                summary: entry.summary,
                default_free: entry.default_free,
                valve_free: entry.valve_free,
                road_free: entry.road_free,
                road_refit: entry.road_refit,
                parameters,
                states: model.states().to_vec(),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builds_every_named_model_and_suggests_for_typos() {
        let truck = TruckParameters::reference();
        for entry in &MODELS {
            let model = build_any_model(entry.name, &truck).unwrap();
            assert_eq!(model.name(), entry.name);
            // Every name in the registry's sets is one the model has, or plays the part of
            // one it has under its laws (`rflow1` for the truck structure's orifice: `c1`);
            // `free_parameters` drops a name with neither, so check the raw sets.
            for &name in entry
                .default_free
                .iter()
                .chain(entry.valve_free)
                .chain(entry.road_free)
                .chain(entry.road_refit)
            {
                assert!(
                    airsus_model::params::same_part_names(name)
                        .iter()
                        .any(|n| model.parameter(n).is_ok()),
                    "{}: `{name}` has no home",
                    entry.name
                );
            }
            for name in entry.free_parameters(Excitation::ALL, &*model) {
                model
                    .parameter(name)
                    .unwrap_or_else(|e| panic!("{}: {e}", entry.name));
            }
        }
        let err = build_any_model("truk", &truck).unwrap_err().to_string();
        assert!(err.contains("(did you mean `truck`?)"), "{err}");
        assert_eq!(MODELS.len(), THESIS_MODELS.len() + 1);
    }

    #[test]
    fn every_model_round_trips_its_parameters_through_a_truck_file() {
        use airsus_data::truck::parse_truck;
        let reference = TruckParameters::reference();
        for entry in &MODELS {
            let mut model = (entry.build)(&reference).unwrap();
            // Move every parameter off its reference value, inside its bounds.
            for info in model.parameter_info().to_vec() {
                let value = model.parameter(info.name).unwrap();
                let moved = if value * 1.01 <= info.upper {
                    value * 1.01
                } else {
                    value * 0.99
                };
                let moved = if moved == 0.0 {
                    0.5 * (info.lower + info.upper).min(1.0)
                } else {
                    moved
                };
                model.set_parameter(info.name, moved).unwrap();
            }
            let mut truck = reference.clone();
            model.write_parameters(&mut truck);
            let text = airsus_data::truck_to_toml(&truck);
            let loaded = parse_truck(&text, std::path::Path::new("t.toml")).unwrap();
            let back = (entry.build)(&loaded.parameters).unwrap();
            for info in model.parameter_info() {
                let (written, read) = (
                    model.parameter(info.name).unwrap(),
                    back.parameter(info.name).unwrap(),
                );
                // Every parameter has a truck-file home, the truck structure's laws and
                // effects included.
                assert!(info.field.is_some(), "{} {}", entry.name, info.name);
                assert_eq!(written, read, "{} {}", entry.name, info.name);
            }
        }
    }

    #[test]
    fn every_description_has_its_parameters_inside_their_bounds() {
        let described = describe_models().unwrap();
        assert_eq!(described.len(), MODELS.len());
        for model in &described {
            assert!(!model.states.is_empty() && !model.parameters.is_empty());
            for p in &model.parameters {
                // m2x's and m2xh's defaults come from the model (the truck file leaves them out).
                assert!(
                    p.default >= p.info.lower && p.default <= p.info.upper,
                    "{} {} = {}",
                    model.name,
                    p.info.name,
                    p.default
                );
            }
        }
    }
}
