//! Physical parameters addressable by short name (SPEC §5 `--free` names).
//!
//! Every full model keeps its parameters in an [`airsus_data::TruckParameters`] (SI units) and
//! exposes the subset it uses through these names. The SPEC's names map one-to-one onto truck
//! file keys, so an estimated parameter set writes back as a truck file
//! ([`crate::SuspensionModel::write_parameters`]).
//!
//! | name | truck-file key | unit |
//! |---|---|---|
//! | `p0`..`p4` | `bellow.effective_area_poly_m2[i]` (eq 5.4) | m², m, 1, 1/m, 1/m² |
//! | `a0`, `a1` | `bellow.cross_section_m2[i]` (eq 5.1) | m², m |
//! | `m2` | `mass.unsprung_kg` | kg |
//! | `ig` | `mass.lever_inertia_kg_m2` | kg m² |
//! | `kf` | `bellow.hinge_friction_n_s_per_m` | N s/m |
//! | `kw` | `tire.stiffness_n_per_m` | N/m |
//! | `kscl` | `geometry.lever_compliance_m_per_n` | m/N |
//! | `rflow1`, `rflow2` | `valve.fill/exhaust_resistance_pa_s_per_mol` | Pa s/mol |
//! | `ksd` (m2x) | `slow_dynamics.force_scale_n_per_m` | N/m |
//! | `ksd` (m2xh) | `slow_dynamics.creep_stiffness_n_per_m` | N/m |
//! | `tsd` (m2xh) | `slow_dynamics.creep_time_constant_s` | s |
//!
//! The bounds are the physically admissible ranges (the estimator's default box); they are
//! deliberately wide — they exclude nonsense (negative masses, stiffness off by 1000), not
//! unlikely values.

use airsus_data::TruckParameters;
use airsus_data::error::nearest_name;

use crate::model::{ModelError, ParameterInfo};

/// Where a named parameter lives in [`TruckParameters`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    EffectiveArea(usize),
    CrossSection(usize),
    Unsprung,
    LeverInertia,
    HingeFriction,
    TireStiffness,
    LeverCompliance,
    FillResistance,
    ExhaustResistance,
    SlowForceScale,
    CreepStiffness,
    CreepTimeConstant,
}

/// The SPEC parameters of every model on Model 2's lever (QCM 2 and the models built on it).
pub const LEVER_MODEL_FIELDS: &[Field] = &[
    Field::EffectiveArea(0),
    Field::EffectiveArea(1),
    Field::EffectiveArea(2),
    Field::EffectiveArea(3),
    Field::EffectiveArea(4),
    Field::CrossSection(0),
    Field::CrossSection(1),
    Field::Unsprung,
    Field::LeverInertia,
    Field::HingeFriction,
    Field::TireStiffness,
    Field::LeverCompliance,
    Field::FillResistance,
    Field::ExhaustResistance,
];

/// One named parameter: its description and its home in the truck parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    pub info: ParameterInfo,
    pub field: Field,
}

const fn info(
    name: &'static str,
    unit: &'static str,
    description: &'static str,
    lower: f64,
    upper: f64,
) -> ParameterInfo {
    ParameterInfo {
        name,
        unit,
        description,
        lower,
        upper,
    }
}

/// All SPEC §5 names plus the creep element's (`m2xh`). `ksd` appears twice with different
/// meanings; a model picks one.
pub const CATALOG: &[Param] = &[
    Param {
        info: info(
            "p0",
            "m²",
            "effective area A_eff = p0 + p1 h + .. + p4 h⁴, constant term (eq 5.4)",
            -1.0,
            1.0,
        ),
        field: Field::EffectiveArea(0),
    },
    Param {
        info: info(
            "p1",
            "m",
            "effective area, linear coefficient (eq 5.4; thesis Table 5.2 misprints 0.08362 for 0.8362)",
            -10.0,
            10.0,
        ),
        field: Field::EffectiveArea(1),
    },
    Param {
        info: info(
            "p2",
            "1",
            "effective area, quadratic coefficient (eq 5.4)",
            -100.0,
            100.0,
        ),
        field: Field::EffectiveArea(2),
    },
    Param {
        info: info(
            "p3",
            "1/m",
            "effective area, cubic coefficient (eq 5.4)",
            -100.0,
            100.0,
        ),
        field: Field::EffectiveArea(3),
    },
    Param {
        info: info(
            "p4",
            "1/m²",
            "effective area, quartic coefficient (eq 5.4)",
            -100.0,
            100.0,
        ),
        field: Field::EffectiveArea(4),
    },
    Param {
        info: info(
            "a0",
            "m²",
            "gas-volume cross-section A = a0 + a1 h, constant term (eq 5.1)",
            1e-3,
            5.0,
        ),
        field: Field::CrossSection(0),
    },
    Param {
        info: info(
            "a1",
            "m",
            "gas-volume cross-section, slope (eq 5.1)",
            -5.0,
            5.0,
        ),
        field: Field::CrossSection(1),
    },
    Param {
        info: info(
            "m2",
            "kg",
            "unsprung mass m2 (axle, wheel; thesis 3.1)",
            10.0,
            3000.0,
        ),
        field: Field::Unsprung,
    },
    Param {
        info: info(
            "ig",
            "kg m²",
            "lever + axle inertia about the hinge I_g (eq 3.8; nominal m2 l1²)",
            1.0,
            1e4,
        ),
        field: Field::LeverInertia,
    },
    Param {
        info: info(
            "kf",
            "N s/m",
            "hinge friction k_f, viscous (eq 3.4)",
            0.0,
            1e6,
        ),
        field: Field::HingeFriction,
    },
    Param {
        info: info("kw", "N/m", "tire stiffness k_w (eq 3.15)", 1e5, 1e8),
        field: Field::TireStiffness,
    },
    Param {
        info: info(
            "kscl",
            "m/N",
            "static lever flex per newton of wheel load k_scl (eq 3.14)",
            0.0,
            1e-5,
        ),
        field: Field::LeverCompliance,
    },
    Param {
        info: info(
            "rflow1",
            "Pa s/mol",
            "fill-channel flow resistance R_flow1 (eq 3.19)",
            1e3,
            1e11,
        ),
        field: Field::FillResistance,
    },
    Param {
        info: info(
            "rflow2",
            "Pa s/mol",
            "exhaust-channel flow resistance R_flow2 (eq 3.19)",
            1e3,
            1e11,
        ),
        field: Field::ExhaustResistance,
    },
    Param {
        info: info(
            "ksd",
            "N/m",
            "slow-force scale k_sd: extra bellow force per metre of OE output (eq 4.4)",
            0.0,
            1e8,
        ),
        field: Field::SlowForceScale,
    },
    Param {
        info: info(
            "ksd",
            "N/m",
            "creep stiffness k_sd of the bellow-wall Maxwell element (m2xh)",
            0.0,
            1e8,
        ),
        field: Field::CreepStiffness,
    },
    Param {
        info: info(
            "tsd",
            "s",
            "creep relaxation time constant τ_sd of the Maxwell element (m2xh)",
            0.1,
            1e5,
        ),
        field: Field::CreepTimeConstant,
    },
];

/// The catalogue entries for `fields`, in that order.
pub fn select(fields: &[Field]) -> Vec<Param> {
    fields
        .iter()
        .filter_map(|f| CATALOG.iter().find(|p| p.field == *f).cloned())
        .collect()
}

/// The SPEC's meaning of a name (`ksd` = the OE force scale), for writing parameters back.
pub fn spec_field(name: &str) -> Option<Field> {
    CATALOG
        .iter()
        .find(|p| p.info.name == name)
        .map(|p| p.field)
}

pub fn get(truck: &TruckParameters, field: Field) -> f64 {
    match field {
        Field::EffectiveArea(i) => truck.bellow.effective_area_poly_m2[i],
        Field::CrossSection(i) => truck.bellow.cross_section_m2[i],
        Field::Unsprung => truck.mass.unsprung_kg,
        Field::LeverInertia => truck.mass.lever_inertia_kg_m2,
        Field::HingeFriction => truck.bellow.hinge_friction_n_s_per_m,
        Field::TireStiffness => truck.tire.stiffness_n_per_m,
        Field::LeverCompliance => truck.geometry.lever_compliance_m_per_n,
        Field::FillResistance => truck.valve.fill_resistance_pa_s_per_mol,
        Field::ExhaustResistance => truck.valve.exhaust_resistance_pa_s_per_mol,
        Field::SlowForceScale => truck.slow_dynamics.force_scale.unwrap_or(f64::NAN),
        Field::CreepStiffness => truck
            .slow_dynamics
            .creep_stiffness_n_per_m
            .unwrap_or(f64::NAN),
        Field::CreepTimeConstant => truck
            .slow_dynamics
            .creep_time_constant_s
            .unwrap_or(f64::NAN),
    }
}

pub fn set(truck: &mut TruckParameters, field: Field, value: f64) {
    match field {
        Field::EffectiveArea(i) => truck.bellow.effective_area_poly_m2[i] = value,
        Field::CrossSection(i) => truck.bellow.cross_section_m2[i] = value,
        Field::Unsprung => truck.mass.unsprung_kg = value,
        Field::LeverInertia => truck.mass.lever_inertia_kg_m2 = value,
        Field::HingeFriction => truck.bellow.hinge_friction_n_s_per_m = value,
        Field::TireStiffness => truck.tire.stiffness_n_per_m = value,
        Field::LeverCompliance => truck.geometry.lever_compliance_m_per_n = value,
        Field::FillResistance => truck.valve.fill_resistance_pa_s_per_mol = value,
        Field::ExhaustResistance => truck.valve.exhaust_resistance_pa_s_per_mol = value,
        Field::SlowForceScale => truck.slow_dynamics.force_scale = Some(value),
        Field::CreepStiffness => truck.slow_dynamics.creep_stiffness_n_per_m = Some(value),
        Field::CreepTimeConstant => truck.slow_dynamics.creep_time_constant_s = Some(value),
    }
}

/// A model's parameter set: the descriptions handed out by `parameter_info` and the lookup.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamSet {
    model: &'static str,
    params: Vec<Param>,
    infos: Vec<ParameterInfo>,
}

impl ParamSet {
    pub fn new(model: &'static str, fields: &[Field]) -> Self {
        let params = select(fields);
        let infos = params.iter().map(|p| p.info.clone()).collect();
        Self {
            model,
            params,
            infos,
        }
    }

    pub fn infos(&self) -> &[ParameterInfo] {
        &self.infos
    }

    /// The parameter called `name`, or the `UnknownParameter` error with a suggestion.
    pub fn lookup(&self, name: &str) -> Result<&Param, ModelError> {
        self.params
            .iter()
            .find(|p| p.info.name == name)
            .ok_or_else(|| {
                let valid: Vec<String> =
                    self.params.iter().map(|p| p.info.name.to_owned()).collect();
                ModelError::UnknownParameter {
                    model: self.model.to_owned(),
                    name: name.to_owned(),
                    suggestion: nearest_name(name, self.params.iter().map(|p| p.info.name)),
                    valid,
                }
            })
    }

    pub fn get(&self, truck: &TruckParameters, name: &str) -> Result<f64, ModelError> {
        Ok(get(truck, self.lookup(name)?.field))
    }

    /// Checks the range (NaN and infinities are out of range) and stores the value.
    pub fn set(
        &self,
        truck: &mut TruckParameters,
        name: &str,
        value: f64,
    ) -> Result<(), ModelError> {
        let p = self.lookup(name)?;
        if !(value >= p.info.lower && value <= p.info.upper) {
            return Err(ModelError::ParameterOutOfRange {
                model: self.model.to_owned(),
                name: name.to_owned(),
                value,
                lower: p.info.lower,
                upper: p.info.upper,
                unit: p.info.unit.to_owned(),
            });
        }
        set(truck, p.field, value);
        Ok(())
    }

    /// Copies this model's parameters from `from` into `to`.
    pub fn write(&self, from: &TruckParameters, to: &mut TruckParameters) {
        for p in &self.params {
            set(to, p.field, get(from, p.field));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spec_names_are_all_there_once_except_ksd() {
        for name in [
            "p0", "p1", "p2", "p3", "p4", "a0", "a1", "m2", "ig", "kf", "kw", "kscl", "rflow1",
            "rflow2", "ksd",
        ] {
            let n = CATALOG.iter().filter(|p| p.info.name == name).count();
            assert_eq!(n, if name == "ksd" { 2 } else { 1 }, "{name}");
        }
    }

    #[test]
    fn reference_truck_is_inside_the_bounds() {
        let mut truck = TruckParameters::reference();
        truck.slow_dynamics.force_scale = Some(1000.0);
        truck.slow_dynamics.creep_stiffness_n_per_m = Some(2.5e4);
        truck.slow_dynamics.creep_time_constant_s = Some(33.0);
        for p in CATALOG {
            let v = get(&truck, p.field);
            assert!(
                v >= p.info.lower && v <= p.info.upper,
                "{} = {v}",
                p.info.name
            );
        }
    }

    #[test]
    fn unknown_name_gets_a_suggestion_and_bad_value_is_rejected() {
        let set_ = ParamSet::new(
            "m1",
            &[
                Field::Unsprung,
                Field::FillResistance,
                Field::ExhaustResistance,
            ],
        );
        let mut truck = TruckParameters::reference();
        let err = set_.set(&mut truck, "rflow", 1e6).unwrap_err();
        match &err {
            ModelError::UnknownParameter {
                suggestion, valid, ..
            } => {
                assert!(
                    suggestion
                        .as_deref()
                        .is_some_and(|s| s.starts_with("rflow")),
                    "{err}"
                );
                assert_eq!(valid, &["m2", "rflow1", "rflow2"]);
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            set_.set(&mut truck, "m2", -1.0),
            Err(ModelError::ParameterOutOfRange { .. })
        ));
        assert!(matches!(
            set_.set(&mut truck, "m2", f64::NAN),
            Err(ModelError::ParameterOutOfRange { .. })
        ));
        set_.set(&mut truck, "m2", 480.0).unwrap();
        assert_eq!(truck.mass.unsprung_kg, 480.0);
        assert_eq!(set_.get(&truck, "m2").unwrap(), 480.0);
    }
}
