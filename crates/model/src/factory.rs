//! The thesis models by name (the command line's `--model`): one [`ModelEntry`] each.
//!
//! The registry of *every* model (these plus the virtual truck's structure) is
//! `airsus_truck::models`; it is what the commands, the study and the report read.

use airsus_data::error::nearest_name;
use airsus_data::{Run, TruckParameters};

use crate::m1::Model1;
use crate::m2::Model2;
use crate::m3::Model3;
use crate::model::{ModelError, SuspensionModel};

/// The effective-area polynomial's coefficients (eq 5.4), freed by every thesis estimation.
const AREA: [&str; 5] = ["p0", "p1", "p2", "p3", "p4"];
/// The valve's flow resistances (eq 3.19) and the gas volume's scale (eq 5.1): only valve
/// action determines them (SPEC §4; a closed-valve run shows only the volume's shape).
/// Freeing `a0` lifts the held-out valve run's pressure fit of every thesis model on the
/// built-in study (m2, data-set 4: −48.7 → 11.8 %).
const FLOW: [&str; 3] = ["rflow1", "rflow2", "a0"];

/// Road-run parameters: the damper table's scale. Only a road strokes the damper fast enough
/// to tell it (a load step moves the body at mm/s); on the virtual truck's variants the true
/// damper differs from the file's table by a factor 0.8-1.25.
const ROAD: [&str; 1] = ["dscl"];

/// What a set of estimation runs excites, and so which parameters its data can determine
/// beyond a model's default set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Excitation {
    /// A run has valve action ([`Run::valve_action`]).
    pub valve: bool,
    /// A run has road input ([`Run::road_action`]).
    pub road: bool,
}

impl Excitation {
    /// Everything excited: every set freed.
    pub const ALL: Self = Self {
        valve: true,
        road: true,
    };

    /// What `runs` excite.
    pub fn of<'a>(runs: impl IntoIterator<Item = &'a Run>) -> Self {
        runs.into_iter().fold(Self::default(), |e, run| Self {
            valve: e.valve || run.valve_action(),
            road: e.road || run.road_action(),
        })
    }

    /// Words for a message: "valve action and road input", or "" when nothing is excited.
    pub fn describe(self) -> String {
        match (self.valve, self.road) {
            (true, true) => "valve action and road input".to_owned(),
            (true, false) => "valve action".to_owned(),
            (false, true) => "road input".to_owned(),
            (false, false) => String::new(),
        }
    }
}

/// One registered model: its name, a line saying what it is, how to build it from a truck
/// file's parameters, and what a grey-box fit frees by default.
#[derive(Debug, Clone, Copy)]
pub struct ModelEntry {
    pub name: &'static str,
    /// One line with the thesis source, for help texts, `airsus models` and the report.
    pub summary: &'static str,
    pub build: fn(&TruckParameters) -> Result<Box<dyn SuspensionModel>, ModelError>,
    /// Freed by default: the thesis' "Estimation 2" sets (Tables 5.10–5.12).
    pub default_free: &'static [&'static str],
    /// Freed as well when the estimation runs have valve action: only then can the data
    /// determine them (SPEC §4).
    pub valve_free: &'static [&'static str],
    /// Freed as well when the estimation runs have road input.
    pub road_free: &'static [&'static str],
    /// Refitted on the estimation runs with road input alone, after the joint estimate, by
    /// the study: the dynamics only a road determines (the tire's stiffness, the lever's
    /// inertia), which a joint fit trades against what the standing runs leave unexplained.
    pub road_refit: &'static [&'static str],
    /// Whether the model starts from the lab's laws in the form its own physics takes them:
    /// the valve from the tank discharges simulated with the gas's cooling, in the law they
    /// call for where the truck file names none, and the effective area with its growth with
    /// pressure read off the force map where the file gives the thesis' quartic. For a model
    /// whose gas exchanges heat and whose area stretches with pressure (the `truck`
    /// structure). The thesis models keep the file's laws and the thesis' readings of the lab
    /// (5.2.2, 5.2.3: isothermal, `F = p A(h)`).
    pub lab_laws: bool,
    /// Whether the model's height is a linear block from load and pressure (an OE, thesis
    /// eq 4.5, Table 5.6) that the study identifies as a submodel on each protocol's own
    /// estimation runs, the one whose load and pressure are least correlated. Model 3's
    /// alone: the study writes the block into the truck file's `model3` table, so the flag
    /// means that table.
    pub height_block_per_protocol: bool,
}

impl ModelEntry {
    /// The parameters a grey-box fit frees by default on runs that excite `excitation`, for
    /// `model` (built by this entry). The sets name the thesis' laws; a name the model
    /// lacks becomes the parameter that plays its part under the model's law (`rflow1` → `c1`
    /// under an orifice valve law).
    pub fn free_parameters(
        &self,
        excitation: Excitation,
        model: &dyn SuspensionModel,
    ) -> Vec<&'static str> {
        let mut free = self.default_free.to_vec();
        if excitation.valve {
            free.extend_from_slice(self.valve_free);
        }
        if excitation.road {
            free.extend_from_slice(self.road_free);
        }
        let has = |name: &str| model.parameter_info().iter().any(|i| i.name == name);
        let mut resolved: Vec<&'static str> = Vec::with_capacity(free.len());
        for name in free {
            match crate::params::same_part_names(name)
                .into_iter()
                .find(|n| has(n))
            {
                Some(name) if !resolved.contains(&name) => resolved.push(name),
                Some(_) => {}
                // The quartic's coefficients name the effective area: under another area
                // law (a spline) its own parameters, every knot, take their part.
                None if is_area_parameter(name) => {
                    for info in model.parameter_info() {
                        if is_area_parameter(info.name) && !resolved.contains(&info.name) {
                            resolved.push(info.name);
                        }
                    }
                }
                None => {}
            }
        }
        resolved
    }
}

/// Whether `name` is a parameter of an effective-area law (`p0`.., `s0`..; not `kap`, the
/// stretch with pressure, which no default set frees).
fn is_area_parameter(name: &str) -> bool {
    matches!(
        crate::params::spec_field(name),
        Some(
            airsus_data::params::Field::EffectiveArea(_) | airsus_data::params::Field::AreaKnot(_)
        )
    )
}

/// The thesis models, in report order.
pub const THESIS_MODELS: &[ModelEntry] = &[
    ModelEntry {
        name: "m1",
        summary: "Model 1: QCM 1, two vertical masses (thesis eq 3.4/4.1)",
        build: |truck| Ok(Box::new(Model1::new(truck))),
        default_free: &[AREA[0], AREA[1], AREA[2], AREA[3], AREA[4], "m2", "kf"],
        valve_free: &FLOW,
        road_free: &ROAD,
        road_refit: &[],
        lab_laws: false,
        height_block_per_protocol: false,
    },
    ModelEntry {
        name: "m2",
        summary: "Model 2: QCM 2, chassis height and lever angle (thesis eq 3.6-3.13/4.2)",
        build: |truck| Ok(Box::new(Model2::new(truck))),
        default_free: &[AREA[0], AREA[1], AREA[2], AREA[3], AREA[4], "m2", "ig"],
        valve_free: &FLOW,
        road_free: &ROAD,
        road_refit: &[],
        lab_laws: false,
        height_block_per_protocol: false,
    },
    ModelEntry {
        name: "m2x",
        summary: "Model 2 extended: + OE slow force from load change (thesis eq 4.3/4.4)",
        build: |truck| Ok(Box::new(Model2::extended(truck)?)),
        default_free: &[
            AREA[0], AREA[1], AREA[2], AREA[3], AREA[4], "m2", "ig", "ksd",
        ],
        valve_free: &FLOW,
        road_free: &ROAD,
        road_refit: &[],
        lab_laws: false,
        height_block_per_protocol: false,
    },
    ModelEntry {
        name: "m2xh",
        summary: "Model 2 + bellow creep force from height change (thesis 6.2)",
        build: |truck| Ok(Box::new(Model2::height_creep(truck))),
        default_free: &[
            AREA[0], AREA[1], AREA[2], AREA[3], AREA[4], "m2", "ig", "ksd", "tsd",
        ],
        valve_free: &FLOW,
        road_free: &ROAD,
        road_refit: &[],
        lab_laws: false,
        height_block_per_protocol: false,
    },
    ModelEntry {
        name: "m3",
        summary: "Model 3: gas and valve physics + OE height model (thesis eq 4.5)",
        build: |truck| Ok(Box::new(Model3::new(truck)?)),
        default_free: &["a1", "kscl"],
        valve_free: &FLOW,
        // Model 3's height is a linear block: it has no damper and ignores the road.
        road_free: &[],
        road_refit: &[],
        lab_laws: false,
        height_block_per_protocol: true,
    },
];

/// The entry called `name` among `entries`, or the `UnknownModel` error with a suggestion.
pub fn find_model<'a>(entries: &'a [ModelEntry], name: &str) -> Result<&'a ModelEntry, ModelError> {
    entries
        .iter()
        .find(|e| e.name == name)
        .ok_or_else(|| ModelError::UnknownModel {
            name: name.to_owned(),
            suggestion: nearest_name(name, entries.iter().map(|e| e.name)),
            valid: entries.iter().map(|e| e.name.to_owned()).collect(),
        })
}

/// Builds the thesis model called `name` (`m1`, `m2`, `m2x`, `m2xh`, `m3`) with `truck`'s
/// parameters. Unknown names get a nearest-name suggestion.
pub fn build_model(
    name: &str,
    truck: &TruckParameters,
) -> Result<Box<dyn SuspensionModel>, ModelError> {
    (find_model(THESIS_MODELS, name)?.build)(truck)
}
