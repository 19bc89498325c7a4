//! Parameters addressable by short name: each model's [`ParamSet`] over the declarations in
//! [`airsus_data::params`] (name, truck-file key, unit, bounds, accessors; declared once
//! there).

use airsus_data::TruckParameters;
use airsus_data::error::nearest_name;
pub use airsus_data::params::{
    CATALOG, Field, LEVER_MODEL_FIELDS, Param, get, law_fields, same_part_names, select, set,
    spec_field,
};

use crate::model::{ModelError, NamedParameters, ParameterInfo};

/// A model's parameter set: the descriptions handed out by `parameter_info` and the lookup.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamSet {
    model: &'static str,
    params: Vec<Param>,
    infos: Vec<ParameterInfo>,
}

impl ParamSet {
    /// The parameters `fields` of `model`, each law's parameters those of `truck`'s law
    /// ([`law_fields`]).
    pub fn new(model: &'static str, fields: &[Field], truck: &TruckParameters) -> Self {
        let params = select(&law_fields(fields, truck));
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
        if !p.info.admits(value) {
            return Err(ModelError::ParameterOutOfRange {
                model: self.model.to_owned(),
                name: name.to_owned(),
                value,
                lower: p.info.lower,
                upper: p.info.upper,
                unit: p.info.unit.to_owned(),
            });
        }
        // The set was built from a truck's laws; a truck under other laws has no home for it.
        if !set(truck, p.field, value) {
            return Err(ModelError::InvalidStructure {
                model: self.model.to_owned(),
                reason: format!(
                    "`{name}` belongs to another law than the truck's (valve law `{}`, effective-area law `{}`)",
                    truck.valve.tag(),
                    truck.bellow.effective_area.tag()
                ),
            });
        }
        Ok(())
    }
}

/// Named parameters kept in a truck's parameters: a [`ParamSet`] over a holder of
/// [`TruckParameters`] (the truck itself, or the virtual truck around it). Every model built on
/// a truck file hands this out as its [`NamedParameters`].
#[derive(Debug, Clone, PartialEq)]
pub struct TruckParams<T = TruckParameters> {
    set: ParamSet,
    holder: T,
}

impl<T: AsRef<TruckParameters> + AsMut<TruckParameters>> TruckParams<T> {
    /// The parameters `fields` of `model` (each law's parameters those of the holder's
    /// truck's law), kept in `holder`.
    pub fn new(model: &'static str, fields: &[Field], holder: T) -> Self {
        Self {
            set: ParamSet::new(model, fields, holder.as_ref()),
            holder,
        }
    }

    pub fn holder(&self) -> &T {
        &self.holder
    }

    /// The holder, to change what is not a named parameter (the set stays as it was built).
    pub fn holder_mut(&mut self) -> &mut T {
        &mut self.holder
    }

    pub fn truck(&self) -> &TruckParameters {
        self.holder.as_ref()
    }
}

impl<T> NamedParameters for TruckParams<T>
where
    T: AsRef<TruckParameters> + AsMut<TruckParameters> + Send + Sync + std::fmt::Debug,
{
    fn infos(&self) -> &[ParameterInfo] {
        self.set.infos()
    }

    fn value(&self, name: &str) -> Result<f64, ModelError> {
        self.set.get(self.holder.as_ref(), name)
    }

    fn set_value(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
        self.set.set(self.holder.as_mut(), name, value)
    }

    fn truck(&self) -> Option<&TruckParameters> {
        Some(self.holder.as_ref())
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
            // A parameter of a law the reference truck does not use (`c1` under the linear
            // valve law), a `truck` structure effect the file leaves to the structure, or a
            // damper correction the file does not name.
            if v.is_nan() {
                assert!(
                    p.field.law_family().is_some()
                        || p.field.location().0 == "effects"
                        || matches!(p.field, airsus_data::params::Field::DamperCorrection(_)),
                    "{}",
                    p.info.name
                );
                continue;
            }
            assert!(
                v >= p.info.lower && v <= p.info.upper,
                "{} = {v}",
                p.info.name
            );
        }
    }

    #[test]
    fn unknown_name_gets_a_suggestion_and_bad_value_is_rejected() {
        let mut truck = TruckParameters::reference();
        let set_ = ParamSet::new(
            "m1",
            &[
                Field::Unsprung,
                Field::FillResistance,
                Field::ExhaustResistance,
            ],
            &truck,
        );
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
