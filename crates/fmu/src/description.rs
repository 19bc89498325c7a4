//! The FMU's variables and `modelDescription.xml` (FMI 2.0 §2.2, schema
//! `fmi2ModelDescription.xsd`), generated from the model registry.
//!
//! The rules followed here (FMI 2.0.5 §2.2.7, and what `fmpy.validation` checks):
//! * inputs carry a `start` value and no `initial` attribute; `valve` is an `Integer`, so its
//!   variability must be given (`discrete`) — only `Real` may be `continuous`;
//! * outputs are `continuous` with `initial="calculated"` and no `start`; each is listed once
//!   under `<ModelStructure><Outputs>` and, being calculated, under `<InitialUnknowns>`
//!   (ordered by index); `dependencies` lists the inputs with direct feed-through (an empty list
//!   means none; co-simulation lists no states when `providesDirectionalDerivative` is false);
//! * parameters are `causality="parameter"` with `initial` exact (the default) and a `start`:
//!   `initial_height_mm` is `fixed` (it only matters at initialisation), the model's parameters
//!   are `tunable` (settable at every communication point, §2.2.7 "fmi2SetXXX can be called …
//!   for Co-Simulation at every communication point … if causality = parameter and variability
//!   = tunable");
//! * every `unit` used is defined under `<UnitDefinitions>`.

use airsus_data::ValveState;
use airsus_data::units::m_from_mm;
use airsus_model::{InitialCondition, InputSample, SuspensionModel};

use crate::config::ExportConfig;
use crate::units::parse_unit;

/// Stands for the GUID while the fingerprint is computed.
pub const GUID_PLACEHOLDER: &str = "{00000000-0000-0000-0000-000000000000}";

/// Value references. Real and Integer variables have separate numbering (FMI 2.0 §2.1.3: a
/// value reference is unique per base type).
pub mod vr {
    pub const WHEEL_LOAD_KG: u32 = 0;
    pub const SUPPLY_KPA: u32 = 1;
    pub const ROAD_MM: u32 = 2;
    pub const HEIGHT_MM: u32 = 3;
    pub const PRESSURE_KPA: u32 = 4;
    pub const INITIAL_HEIGHT_MM: u32 = 5;
    pub const ROAD_RATE_MM_S: u32 = 6;
    /// The model's parameters follow in registry order.
    pub const FIRST_PARAMETER: u32 = 7;
    /// The only Integer.
    pub const VALVE: u32 = 0;
}

/// Start values of the inputs: the reference truck at its nominal load, valve closed, the
/// supply at its nominal pressure, a level road (the defaults of `airsus road` and `control`).
pub const DEFAULT_WHEEL_LOAD_KG: f64 = 3390.0;
pub const DEFAULT_VALVE: i32 = 0;
pub const DEFAULT_SUPPLY_KPA: f64 = 850.0;
pub const DEFAULT_ROAD_MM: f64 = 0.0;
pub const DEFAULT_ROAD_RATE_MM_S: f64 = 0.0;

/// The log categories the library offers (standard names, FMI 2.0 §2.2.4).
pub const LOG_CATEGORIES: &[(&str, &str)] = &[
    (
        "logEvents",
        "Initialisation, parameter changes, reset (only with logging on)",
    ),
    (
        "logStatusWarning",
        "Messages of functions returning fmi2Warning",
    ),
    (
        "logStatusDiscard",
        "Messages of functions returning fmi2Discard",
    ),
    (
        "logStatusError",
        "Messages of functions returning fmi2Error (on unless switched off)",
    ),
    (
        "logStatusFatal",
        "Messages of functions returning fmi2Fatal",
    ),
    ("logAll", "All of the above"),
];

/// What a variable means to the slave.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    WheelLoad,
    Valve,
    Supply,
    Road,
    /// The road height's rate: what a damped tire feels.
    RoadRate,
    Height,
    Pressure,
    InitialHeight,
    /// A model parameter; the variable's name is its registry name.
    Parameter,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarType {
    Real,
    Integer,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    Input,
    Output,
    Parameter,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variability {
    Continuous,
    Discrete,
    Fixed,
    Tunable,
}

impl VarType {
    fn element(self) -> &'static str {
        match self {
            Self::Real => "Real",
            Self::Integer => "Integer",
        }
    }
}

impl Causality {
    fn as_str(self) -> &'static str {
        match self {
            Self::Input => "input",
            Self::Output => "output",
            Self::Parameter => "parameter",
        }
    }
}

impl Variability {
    fn as_str(self) -> &'static str {
        match self {
            Self::Continuous => "continuous",
            Self::Discrete => "discrete",
            Self::Fixed => "fixed",
            Self::Tunable => "tunable",
        }
    }
}

/// One `<ScalarVariable>`.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    pub name: String,
    pub value_reference: u32,
    pub var_type: VarType,
    pub causality: Causality,
    pub variability: Variability,
    pub role: Role,
    pub description: String,
    pub unit: Option<String>,
    pub start: Option<f64>,
    pub min: Option<f64>,
    pub max: Option<f64>,
}

/// Which inputs each output depends on at a communication point (direct feed-through), in
/// input order `[wheel_load_kg, valve, supply_kpa, road_mm, road_rate_mm_s]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Feedthrough {
    pub height: [bool; 5],
    pub pressure: [bool; 5],
}

/// The inputs' start values as a model input sample (SI units).
pub fn default_inputs() -> InputSample {
    InputSample {
        wheel_load_kg: DEFAULT_WHEEL_LOAD_KG,
        valve: ValveState::Closed,
        supply_gauge_pa: DEFAULT_SUPPLY_KPA * airsus_data::units::PA_PER_KPA,
        road_height_m: m_from_mm(DEFAULT_ROAD_MM),
        road_rate_m_s: m_from_mm(DEFAULT_ROAD_RATE_MM_S),
    }
}

/// The FMU's variables in `<ModelVariables>` order (the ScalarVariable index of the n-th is
/// n + 1): the five inputs, the two outputs, `initial_height_mm`, the model's parameters.
pub fn variables(model: &dyn SuspensionModel, initial_height_mm: f64) -> Vec<Variable> {
    let real = |name: &str,
                value_reference: u32,
                causality: Causality,
                variability: Variability,
                role: Role,
                description: &str,
                unit: &str| Variable {
        name: name.to_owned(),
        value_reference,
        var_type: VarType::Real,
        causality,
        variability,
        role,
        description: description.to_owned(),
        unit: (!unit.is_empty()).then(|| unit.to_owned()),
        start: None,
        min: None,
        max: None,
    };
    let mut vars = vec![
        Variable {
            start: Some(DEFAULT_WHEEL_LOAD_KG),
            min: Some(0.0),
            ..real(
                "wheel_load_kg",
                vr::WHEEL_LOAD_KG,
                Causality::Input,
                Variability::Continuous,
                Role::WheelLoad,
                "Wheel load m_tot: the mass a scale under the modelled wheel shows",
                "kg",
            )
        },
        Variable {
            name: "valve".to_owned(),
            value_reference: vr::VALVE,
            var_type: VarType::Integer,
            causality: Causality::Input,
            variability: Variability::Discrete,
            role: Role::Valve,
            description: "Valve state: 0 closed, 1 fill (air in), 2 exhaust (air out)".to_owned(),
            unit: None,
            start: Some(f64::from(DEFAULT_VALVE)),
            min: Some(0.0),
            max: Some(2.0),
        },
        Variable {
            start: Some(DEFAULT_SUPPLY_KPA),
            ..real(
                "supply_kpa",
                vr::SUPPLY_KPA,
                Causality::Input,
                Variability::Continuous,
                Role::Supply,
                "Supply (actuator tank) gauge pressure",
                "kPa",
            )
        },
        Variable {
            start: Some(DEFAULT_ROAD_MM),
            ..real(
                "road_mm",
                vr::ROAD_MM,
                Causality::Input,
                Variability::Continuous,
                Role::Road,
                "Road height under the wheel",
                "mm",
            )
        },
        Variable {
            start: Some(DEFAULT_ROAD_RATE_MM_S),
            ..real(
                "road_rate_mm_s",
                vr::ROAD_RATE_MM_S,
                Causality::Input,
                Variability::Continuous,
                Role::RoadRate,
                "Rate of the road height (its derivative): the road moves at it over a step; 0 holds the road",
                "mm/s",
            )
        },
        real(
            "height_mm",
            vr::HEIGHT_MM,
            Causality::Output,
            Variability::Continuous,
            Role::Height,
            "Axle-to-chassis height as the sensor reads it (incl. the lever's static flex)",
            "mm",
        ),
        real(
            "pressure_kpa",
            vr::PRESSURE_KPA,
            Causality::Output,
            Variability::Continuous,
            Role::Pressure,
            "Bellow gauge pressure",
            "kPa",
        ),
        Variable {
            start: Some(initial_height_mm),
            min: Some(0.0),
            ..real(
                "initial_height_mm",
                vr::INITIAL_HEIGHT_MM,
                Causality::Parameter,
                Variability::Fixed,
                Role::InitialHeight,
                "Sensor height of the static equilibrium the FMU starts in, under the inputs at the start time",
                "mm",
            )
        },
    ];
    for (k, info) in model.parameter_info().iter().enumerate() {
        let value = model.parameter(info.name).unwrap_or(f64::NAN);
        let inside = (info.lower..=info.upper).contains(&value);
        let offset = u32::try_from(k).unwrap_or(u32::MAX - vr::FIRST_PARAMETER);
        vars.push(Variable {
            start: Some(value),
            min: inside.then_some(info.lower),
            max: inside.then_some(info.upper),
            ..real(
                info.name,
                vr::FIRST_PARAMETER + offset,
                Causality::Parameter,
                Variability::Tunable,
                Role::Parameter,
                info.description,
                info.unit,
            )
        });
    }
    vars
}

/// Which inputs reach the outputs directly: probed on the model's output map at the static
/// equilibrium under the default inputs (perturbing one input at a time). The sensor height
/// always depends on the wheel load (the lever flex of eq 3.14, present in every model even
/// when `kscl` happens to be 0, since a host may tune it).
pub fn feedthrough(model: &dyn SuspensionModel, initial_height_mm: f64) -> Feedthrough {
    let mut ft = Feedthrough {
        height: [true, false, false, false, false],
        pressure: [false; 5],
    };
    let u0 = default_inputs();
    let ic = InitialCondition::SensorHeight {
        height_m: m_from_mm(initial_height_mm),
    };
    let Ok(x0) = model.initial_state(&u0, &ic) else {
        return ft;
    };
    let y0 = model.output(&x0, &u0);
    let perturbed = [
        InputSample {
            wheel_load_kg: u0.wheel_load_kg + 100.0,
            ..u0
        },
        InputSample {
            valve: ValveState::Fill,
            ..u0
        },
        InputSample {
            supply_gauge_pa: u0.supply_gauge_pa + 1e5,
            ..u0
        },
        InputSample {
            road_height_m: u0.road_height_m + 0.01,
            ..u0
        },
        InputSample {
            road_rate_m_s: u0.road_rate_m_s + 0.1,
            ..u0
        },
    ];
    for (k, u) in perturbed.iter().enumerate() {
        let y = model.output(&x0, u);
        // Exact comparison on purpose: an input the output map does not read gives bit-equal
        // outputs; a non-finite output counts as a dependency.
        ft.height[k] |= y.sensor_height_m != y0.sensor_height_m;
        ft.pressure[k] |= y.bellow_gauge_pa != y0.bellow_gauge_pa;
    }
    ft
}

/// `modelDescription.xml` for these variables. `guid` is written as given
/// ([`GUID_PLACEHOLDER`] while fingerprinting).
pub fn model_description(
    model: &dyn SuspensionModel,
    config: &ExportConfig,
    variables: &[Variable],
    feedthrough: &Feedthrough,
    guid: &str,
) -> String {
    let mut x = String::new();
    x.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    x.push_str(&format!(
        "<fmiModelDescription\n  fmiVersion=\"2.0\"\n  modelName=\"airsus_{}\"\n  guid=\"{}\"\n  description=\"{}\"\n  version=\"{}\"\n  generationTool=\"airsus {}\"\n  variableNamingConvention=\"flat\">\n",
        escape(&config.model),
        escape(guid),
        escape(model.description()),
        escape(&config.airsus_version),
        env!("CARGO_PKG_VERSION"),
    ));
    x.push_str(&format!(
        "  <CoSimulation\n    modelIdentifier=\"{}\"\n    canHandleVariableCommunicationStepSize=\"true\"\n    canNotUseMemoryManagementFunctions=\"true\"\n    canGetAndSetFMUstate=\"true\"\n    canSerializeFMUstate=\"false\"\n    providesDirectionalDerivative=\"false\"/>\n",
        crate::MODEL_IDENTIFIER
    ));

    let mut units: Vec<&str> = Vec::new();
    for u in variables.iter().filter_map(|v| v.unit.as_deref()) {
        if !units.contains(&u) {
            units.push(u);
        }
    }
    if !units.is_empty() {
        x.push_str("  <UnitDefinitions>\n");
        for u in &units {
            match parse_unit(u) {
                Some(base) => x.push_str(&format!(
                    "    <Unit name=\"{}\">{}</Unit>\n",
                    escape(u),
                    base.to_xml()
                )),
                None => x.push_str(&format!("    <Unit name=\"{}\"/>\n", escape(u))),
            }
        }
        x.push_str("  </UnitDefinitions>\n");
    }

    x.push_str("  <LogCategories>\n");
    for (name, description) in LOG_CATEGORIES {
        x.push_str(&format!(
            "    <Category name=\"{name}\" description=\"{}\"/>\n",
            escape(description)
        ));
    }
    x.push_str("  </LogCategories>\n");
    x.push_str(&format!(
        "  <DefaultExperiment startTime=\"0.0\" stopTime=\"60.0\" tolerance=\"{:?}\" stepSize=\"0.1\"/>\n",
        crate::slave::DEFAULT_RTOL
    ));

    x.push_str("  <ModelVariables>\n");
    for (i, v) in variables.iter().enumerate() {
        x.push_str(&format!("    <!-- index {} -->\n", i + 1));
        x.push_str(&format!(
            "    <ScalarVariable name=\"{}\" valueReference=\"{}\" description=\"{}\" causality=\"{}\" variability=\"{}\"",
            escape(&v.name),
            v.value_reference,
            escape(&v.description),
            v.causality.as_str(),
            v.variability.as_str()
        ));
        if v.causality == Causality::Output {
            x.push_str(" initial=\"calculated\"");
        }
        x.push_str(">\n");
        x.push_str(&format!("      <{}", v.var_type.element()));
        if let Some(u) = &v.unit {
            x.push_str(&format!(" unit=\"{}\"", escape(u)));
        }
        let number = |value: f64| match v.var_type {
            // Integer attributes are xs:int; the values here are small whole numbers.
            VarType::Integer => format!("{}", value as i64),
            VarType::Real => format!("{value:?}"),
        };
        if let Some(min) = v.min {
            x.push_str(&format!(" min=\"{}\"", number(min)));
        }
        if let Some(max) = v.max {
            x.push_str(&format!(" max=\"{}\"", number(max)));
        }
        if let Some(start) = v.start {
            x.push_str(&format!(" start=\"{}\"", number(start)));
        }
        x.push_str("/>\n    </ScalarVariable>\n");
    }
    x.push_str("  </ModelVariables>\n");

    let index_of = |role: Role| {
        variables
            .iter()
            .position(|v| v.role == role)
            .map_or(0, |i| i + 1)
    };
    let inputs = [
        index_of(Role::WheelLoad),
        index_of(Role::Valve),
        index_of(Role::Supply),
        index_of(Role::Road),
        index_of(Role::RoadRate),
    ];
    let dependencies = |flags: &[bool; 5]| {
        let mut list: Vec<usize> = inputs
            .iter()
            .zip(flags)
            .filter(|(_, on)| **on)
            .map(|(index, _)| *index)
            .collect();
        list.sort_unstable();
        list.iter()
            .map(usize::to_string)
            .collect::<Vec<_>>()
            .join(" ")
    };
    let (height, pressure) = (index_of(Role::Height), index_of(Role::Pressure));
    x.push_str("  <ModelStructure>\n    <Outputs>\n");
    x.push_str(&format!(
        "      <Unknown index=\"{height}\" dependencies=\"{}\"/>\n",
        dependencies(&feedthrough.height)
    ));
    x.push_str(&format!(
        "      <Unknown index=\"{pressure}\" dependencies=\"{}\"/>\n",
        dependencies(&feedthrough.pressure)
    ));
    x.push_str("    </Outputs>\n    <InitialUnknowns>\n");
    // Ordered by index; `dependencies` left out: at initialisation the outputs depend on the
    // inputs and on every exact variable (the parameters, the initial height).
    x.push_str(&format!("      <Unknown index=\"{height}\"/>\n"));
    x.push_str(&format!("      <Unknown index=\"{pressure}\"/>\n"));
    x.push_str("    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n");
    x
}

/// XML attribute text.
fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\n' => out.push_str("&#10;"),
            '\r' => out.push_str("&#13;"),
            '\t' => out.push_str("&#9;"),
            // Other control characters are not allowed in XML 1.0 at all.
            c if c.is_control() => out.push(' '),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{DEFAULT_INITIAL_HEIGHT_MM, Prepared};
    use airsus_data::TruckParameters;

    fn prepared(model: &str) -> Prepared {
        let config = ExportConfig::new(
            model,
            &TruckParameters::reference(),
            DEFAULT_INITIAL_HEIGHT_MM,
        )
        .unwrap();
        Prepared::new(config).unwrap()
    }

    #[test]
    fn every_model_gets_its_parameters_as_tunable_variables() {
        for (name, _) in airsus_truck::models::all_model_names() {
            let p = prepared(name);
            let params: Vec<&str> = p.model.parameter_info().iter().map(|i| i.name).collect();
            let tunable: Vec<&str> = p
                .variables
                .iter()
                .filter(|v| v.variability == Variability::Tunable)
                .map(|v| v.name.as_str())
                .collect();
            assert_eq!(tunable, params, "{name}");
            // Value references are unique per type.
            let mut reals: Vec<u32> = p
                .variables
                .iter()
                .filter(|v| v.var_type == VarType::Real)
                .map(|v| v.value_reference)
                .collect();
            reals.sort_unstable();
            reals.dedup();
            assert_eq!(reals.len(), p.variables.len() - 1, "{name}");
            // Names are unique.
            let mut names: Vec<&str> = p.variables.iter().map(|v| v.name.as_str()).collect();
            names.sort_unstable();
            names.dedup();
            assert_eq!(names.len(), p.variables.len(), "{name}");
        }
    }

    #[test]
    fn the_model_description_follows_the_fmi_rules() {
        let p = prepared("m2");
        let xml = &p.model_description;
        assert!(xml.starts_with("<?xml version=\"1.0\" encoding=\"UTF-8\"?>"));
        assert!(xml.contains("fmiVersion=\"2.0\""));
        assert!(xml.contains("modelIdentifier=\"airsus_fmu\""));
        assert!(xml.contains("canHandleVariableCommunicationStepSize=\"true\""));
        // Inputs: a start, no `initial`.
        let input = xml
            .lines()
            .find(|l| l.contains("name=\"wheel_load_kg\""))
            .unwrap();
        assert!(!input.contains("initial="), "{input}");
        assert!(xml.contains("<Integer min=\"0\" max=\"2\" start=\"0\"/>"));
        // Outputs: calculated, without a start.
        let output = xml
            .lines()
            .skip_while(|l| !l.contains("name=\"height_mm\""))
            .take(2)
            .collect::<Vec<_>>()
            .join("\n");
        assert!(output.contains("initial=\"calculated\""), "{output}");
        assert!(!output.contains("start="), "{output}");
        // Height (index 6, after the five inputs) feeds through from the wheel load (index 1)
        // only, pressure from nothing; neither from the road's rate (index 5).
        assert!(
            xml.contains("<Unknown index=\"6\" dependencies=\"1\"/>"),
            "{xml}"
        );
        assert!(
            xml.contains("<Unknown index=\"7\" dependencies=\"\"/>"),
            "{xml}"
        );
        assert!(xml.contains(
            "<InitialUnknowns>\n      <Unknown index=\"6\"/>\n      <Unknown index=\"7\"/>"
        ));
        // Every unit is defined.
        for v in &p.variables {
            if let Some(u) = &v.unit {
                assert!(
                    xml.contains(&format!("<Unit name=\"{}\"", escape(u))),
                    "{u}"
                );
            }
        }
        assert!(xml.contains(
            "<Unit name=\"kPa\"><BaseUnit kg=\"1\" m=\"-1\" s=\"-2\" factor=\"1000.0\"/></Unit>"
        ));
    }

    #[test]
    fn escape_keeps_attributes_well_formed() {
        assert_eq!(escape("a<b & \"c\"\n"), "a&lt;b &amp; &quot;c&quot;&#10;");
        assert_eq!(escape("τ ≤ m²"), "τ ≤ m²");
    }
}
