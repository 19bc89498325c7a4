//! Truck parameter files (SPEC §5): the nominal physical parameters of one corner.
//!
//! Sections and keys are fixed by the contract. A key marked *est* in the SPEC may be omitted:
//! the pipeline estimates it, and the loader reports which built-in value it used instead.
//! Values are checked for plausibility at load time, which catches unit slips (a height in mm,
//! a temperature in °C, a pressure in Pa) before they become a strange simulation.
//!
//! The optional `[slow_dynamics]` section is ours (the SPEC allows models with more parameters
//! to add their own): the OE model of thesis Table 5.4/5.5 and its force scale `k_sd`; so are
//! `[model3]` (Model 3's OE model) and `[effects]` (the `truck` structure's wall, gas and
//! supply line).
//!
//! The effective area, the gas volume and the valve flow are laws ([`crate::laws`]): the
//! SPEC's keys are the thesis' laws, and another law is a tagged table
//! (`[bellow.effective_area]`, `[bellow.gas_volume]`, `[valve]` with `law = ".."`).
//! Declared parameters with a key of their own are read and written from one table,
//! `DECLARED_KEYS`.

use std::fmt::Write as _;
use std::path::Path;
use std::sync::LazyLock;

use serde::Deserialize;

use crate::atomic::write_text_atomically;
use crate::error::{DataError, DataErrorKind, Location};
use crate::laws::{EffectiveAreaLaw, GasVolumeLaw, LawTable, ValveFlowLaw, check_declared};
use crate::params::{Field, get, set};
use crate::toml_file::{
    TableSchema, check_finite, check_keys, deserialize, find_key_line, parse_toml,
};
use crate::units::PA_PER_KPA;

/// Ambient conditions.
#[derive(Debug, Clone, PartialEq)]
pub struct Environment {
    pub gravity_m_s2: f64,
    pub gas_constant_j_mol_k: f64,
    /// Gas temperature, assumed equal to ambient (thesis 3.1.3).
    pub temperature_k: f64,
    /// Absolute ambient pressure, Pa.
    pub ambient_pressure_pa: f64,
}

/// Lever geometry (thesis Fig 2.4/2.5).
#[derive(Debug, Clone, PartialEq)]
pub struct Geometry {
    /// Chassis bottom to hinge, m.
    pub h0_m: f64,
    /// Hinge to axle along the lever, m.
    pub l1_m: f64,
    /// Axle to bellow centre along the lever, m.
    pub l2_m: f64,
    /// Axle to damper, m.
    pub l3_m: f64,
    /// `k_scl`: static flex of the leaf-spring lever per newton on the wheel (eq 3.14), m/N.
    pub lever_compliance_m_per_n: f64,
}

/// The reference truck's effective area, `p0..p4` of eq 5.4 (thesis Table 5.2 with the
/// corrected `p1 = 0.8362`).
pub const REFERENCE_AREA_POLY_M2: [f64; 5] = [-0.0289, 0.8362, -3.0698, 4.9616, -2.9941];

impl Geometry {
    /// Lever gain `k_l = (l1 + l2) / l1` (thesis 3.1.1).
    pub fn lever_gain(&self) -> f64 {
        (self.l1_m + self.l2_m) / self.l1_m
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct MassParameters {
    /// `m2`: unsprung mass, kg.
    pub unsprung_kg: f64,
    /// `I_g`: lever inertia about the hinge, kg m².
    pub lever_inertia_kg_m2: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct TireParameters {
    /// `k_w`, N/m (eq 3.15).
    pub stiffness_n_per_m: f64,
    /// `c_w`, N s/m: the tire's own damping beside eq 3.15's spring (key
    /// `tire.damping_n_s_per_m`, default 0, the thesis' tire). A rolling tire dissipates
    /// energy in its rubber; it damps the wheel-hop mode, which only a road excites.
    pub damping_n_s_per_m: f64,
}

/// Damper force against extension velocity (+ = extension/rebound), piecewise affine.
#[derive(Debug, Clone, PartialEq)]
pub struct DamperTable {
    pub velocity_m_s: Vec<f64>,
    pub force_n: Vec<f64>,
    /// `dscl`: every force of the table times this (key `damper.scale`, default 1). A
    /// damper's table is measured on one unit or read from a data sheet; the one on the truck
    /// damps more or less (wear, temperature, tolerance) with about the same shape, so one
    /// factor is what road runs can estimate where the table's points are not.
    pub scale: f64,
    /// `dc0, dc1, ..`: each point's force times this too (key `damper.correction`, one
    /// factor per point; empty: none, every factor 1). Where the truck's damper differs from
    /// its table in shape, not only in level (a worn valve stage, a data sheet of another
    /// build), a road run that strokes the damper over several velocities determines the
    /// points it reaches.
    pub correction: Vec<f64>,
}

impl DamperTable {
    /// A table of `velocity_m_s` and `force_n` at scale 1, uncorrected.
    pub fn new(velocity_m_s: Vec<f64>, force_n: Vec<f64>) -> Self {
        Self {
            velocity_m_s,
            force_n,
            scale: 1.0,
            correction: Vec::new(),
        }
    }

    /// The force of point `i` as the truck's damper gives it: the table's, times the scale
    /// and the point's correction.
    pub fn corrected_force_n(&self, i: usize) -> f64 {
        self.force_n[i] * self.scale * self.correction.get(i).copied().unwrap_or(1.0)
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct BellowParameters {
    /// The effective area `A_eff` (eq 3.16), a law: the thesis' quartic in height `p0..p4`
    /// (eq 5.4), or another ([`crate::laws`]).
    pub effective_area: EffectiveAreaLaw,
    /// The gas volume `V(h)` (eq 3.17), a law: the thesis' `h (A0 + A1 h)` (eq 5.1), or
    /// another.
    pub gas_volume: GasVolumeLaw,
    /// `k_f`: hinge friction, N s/m (QCM 1).
    pub hinge_friction_n_s_per_m: f64,
}

/// The supply line's volume between the tank and the valve, m³ (a litre: a few metres of
/// 16-20 mm pipe and the valve block). With `rline` it sets how fast the line drains while the
/// valve fills (`V rline / RT`, 0.1-0.2 s); a file names only the resistance, which is what a
/// fit can tell from the bellow's pressure.
pub const SUPPLY_LINE_VOLUME_M3: f64 = 1.0e-3;

/// The `truck` structure's wall, gas and supply-line parameters: the optional section
/// `[effects]` (ours, like `[slow_dynamics]`), every key optional. `None`: not given; the
/// structure then uses its built-in value. Thesis models read only the supply line from it:
/// given, it sits between the logged tank and every model's valve.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EffectValues {
    /// `kc`: creep stiffness of the bellow wall (Maxwell element), N/m.
    pub creep_stiffness_n_per_m: Option<f64>,
    /// `tc`: its relaxation time, s.
    pub creep_time_constant_s: Option<f64>,
    /// `fc`: the wall's sliding friction (Dahl), N.
    pub friction_force_n: Option<f64>,
    /// `kdahl`: its pre-sliding stiffness, N/m.
    pub friction_stiffness_n_per_m: Option<f64>,
    /// `tth`: thermal time constant of the bellow gas, s.
    pub thermal_time_constant_s: Option<f64>,
    /// `rline`: supply line resistance between tank and valve, Pa s/mol. The line's volume
    /// is [`SUPPLY_LINE_VOLUME_M3`].
    pub line_resistance_pa_s_per_mol: Option<f64>,
}

impl EffectValues {
    /// The slot of one of these values; `None` for any other field.
    pub fn slot(&mut self, field: Field) -> Option<&mut Option<f64>> {
        Some(match field {
            Field::WallCreepStiffness => &mut self.creep_stiffness_n_per_m,
            Field::WallCreepTime => &mut self.creep_time_constant_s,
            Field::WallFrictionForce => &mut self.friction_force_n,
            Field::WallFrictionStiffness => &mut self.friction_stiffness_n_per_m,
            Field::GasThermalTime => &mut self.thermal_time_constant_s,
            Field::LineResistance => &mut self.line_resistance_pa_s_per_mol,
            _ => return None,
        })
    }
}

/// The slow-dynamics OE block of Model 2 extended (thesis 4.2.1, Tables 5.4/5.5).
#[derive(Debug, Clone, PartialEq)]
pub struct SlowDynamics {
    /// Numerator `b1..b_nb` of `B(q)/F(q)`.
    pub oe_b: Vec<f64>,
    /// Denominator `f1..f_nf` (the leading 1 is implicit).
    pub oe_f: Vec<f64>,
    /// Input delay in samples.
    pub oe_nk: usize,
    /// Sample time the OE model was identified at, s.
    pub oe_sample_time_s: f64,
    /// `k_sd`, the scale from the OE output to the extra bellow force, N per metre of OE output
    /// (Model 2 extended, `m2x`). `None`: the model uses one tenth of the bellow force that
    /// carries the thesis' initial condition (sprung 2830 kg, data-set 1), thesis Table 5.9.
    pub force_scale: Option<f64>,
    /// Creep element of the height-driven variant (`m2xh`): stiffness `k_sd` of the Maxwell
    /// element (spring in series with a dashpot) in parallel with the bellow, N/m of bellow
    /// height. `None`: the model's default. Optional key `creep_stiffness_n_per_m`.
    pub creep_stiffness_n_per_m: Option<f64>,
    /// Relaxation time constant `τ_sd` of that element, s. `None`: the model's default (the
    /// thesis OE pole, `-Ts / ln(-f1)` ≈ 33 s). Optional key `creep_time_constant_s`.
    pub creep_time_constant_s: Option<f64>,
}

impl Default for SlowDynamics {
    fn default() -> Self {
        Self {
            oe_b: vec![-8.672e-8],
            oe_f: vec![-0.997],
            oe_nk: 2,
            oe_sample_time_s: 0.1,
            force_scale: None,
            creep_stiffness_n_per_m: None,
            creep_time_constant_s: None,
        }
    }
}

/// The two-input OE model of Model 3 (thesis 4.3, eq 4.5; Tables 5.6–5.8), from wheel load and
/// bellow pressure to bellow height. Optional section `[model3]` (ours, like `[slow_dynamics]`).
///
/// Units are those the thesis logged and identified in (thesis 2.2, 5.1): load in **kg**,
/// bellow pressure in **kPa gauge**, bellow height in **mm**. The model is used in deviation
/// form (the static relation removed, as in thesis 5.2.4): inputs and output are changes from
/// the initial equilibrium. Polynomials in `q⁻¹` as in MATLAB: `B = b1 q^-nk + b2 q^-nk-1 ..`,
/// `F = 1 + f1 q^-1 + ..` (the leading 1 implicit).
#[derive(Debug, Clone, PartialEq)]
pub struct Model3Oe {
    /// Load → height numerator `b1..`, mm/kg (Table 5.7).
    pub load_b: Vec<f64>,
    /// Load → height denominator `f1..` (Table 5.7).
    pub load_f: Vec<f64>,
    /// Load input delay, samples (Table 5.6).
    pub load_nk: usize,
    /// Pressure → height numerator `b1..`, mm/kPa (Table 5.8).
    pub pressure_b: Vec<f64>,
    /// Pressure → height denominator `f1..` (Table 5.8).
    pub pressure_f: Vec<f64>,
    /// Pressure input delay, samples (Table 5.6).
    pub pressure_nk: usize,
    /// Sample time of the identification, s.
    pub sample_time_s: f64,
}

impl Default for Model3Oe {
    /// Thesis Tables 5.6–5.8 as printed.
    fn default() -> Self {
        Self {
            load_b: vec![1.093e-5, 1.093e-5],
            load_f: vec![-1.84, 0.8404],
            load_nk: 1,
            pressure_b: vec![-5.801e-9, 5.194e-9],
            pressure_f: vec![-0.5059, 0.4933],
            pressure_nk: 1,
            sample_time_s: 0.1,
        }
    }
}

/// All parameters of one corner, SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct TruckParameters {
    pub environment: Environment,
    pub geometry: Geometry,
    pub mass: MassParameters,
    pub tire: TireParameters,
    pub damper: DamperTable,
    pub bellow: BellowParameters,
    /// The valve's flow law: the thesis' linear resistances (eq 3.19) or another.
    pub valve: ValveFlowLaw,
    /// Whether the file names the thesis' linear law (`[valve] law = "linear_resistance"`);
    /// false under another law, which a file can only name. The SPEC's form names none: the
    /// thesis models then take the thesis' resistances and the `truck` structure, whose valve
    /// is an ISO 6358 orifice unless told otherwise, its orifice. A file that names the linear
    /// law gives every model, the structure too, the linear law.
    pub valve_law_named: bool,
    pub slow_dynamics: SlowDynamics,
    /// Model 3's OE block (optional section `[model3]`; default thesis Tables 5.6–5.8).
    pub model3: Model3Oe,
    /// The `truck` structure's effects (optional section `[effects]`).
    pub effects: EffectValues,
}

impl TruckParameters {
    /// The SPEC's reference truck: a 4x2 tractor's rear drive axle, with the corrected
    /// effective-area coefficient `p1 = 0.8362` (thesis Table 5.2 prints 0.08362).
    pub fn reference() -> Self {
        Self {
            environment: Environment {
                gravity_m_s2: 9.81,
                gas_constant_j_mol_k: 8.314462618,
                temperature_k: 293.15,
                ambient_pressure_pa: 101.325 * PA_PER_KPA,
            },
            geometry: Geometry {
                h0_m: 0.10,
                l1_m: 0.62,
                l2_m: 0.28,
                l3_m: 0.12,
                lever_compliance_m_per_n: 2.0e-7,
            },
            mass: MassParameters {
                unsprung_kg: 520.0,
                lever_inertia_kg_m2: 200.0,
            },
            tire: TireParameters {
                stiffness_n_per_m: 1.8e6,
                damping_n_s_per_m: 0.0,
            },
            damper: DamperTable::new(
                vec![-1.0, -0.5, -0.1, 0.0, 0.1, 0.5, 1.0],
                vec![-6000.0, -4000.0, -1500.0, 0.0, 3000.0, 9000.0, 13000.0],
            ),
            bellow: BellowParameters {
                effective_area: EffectiveAreaLaw::polynomial(REFERENCE_AREA_POLY_M2),
                gas_volume: GasVolumeLaw::cross_section(*GasVolumeLaw::REFERENCE_CROSS_SECTION_M2),
                hinge_friction_n_s_per_m: 0.1,
            },
            valve: ValveFlowLaw::LinearResistance {
                fill_pa_s_per_mol: 2.5e6,
                exhaust_pa_s_per_mol: 1.5e6,
            },
            valve_law_named: false,
            slow_dynamics: SlowDynamics::default(),
            model3: Model3Oe::default(),
            effects: EffectValues::default(),
        }
    }
}

// So that a model's parameter store can hold the truck itself or something around it.
impl AsRef<TruckParameters> for TruckParameters {
    fn as_ref(&self) -> &TruckParameters {
        self
    }
}

impl AsMut<TruckParameters> for TruckParameters {
    fn as_mut(&mut self) -> &mut TruckParameters {
        self
    }
}

/// A loaded truck file: the parameters and the *est* keys the file left out, each filled with
/// the reference truck's value (or, for `lever_inertia_kg_m2`, `m2 * l1²`).
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedTruck {
    pub parameters: TruckParameters,
    pub defaulted: Vec<DefaultedKey>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct DefaultedKey {
    /// `section.key` as in the file.
    pub key: String,
    /// The value used, as it would be written in the file.
    pub value: String,
}

/// How a declared parameter with a key of its own (not an element of a law's table) stands in
/// the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Presence {
    /// The file must give it.
    Required,
    /// The file may leave it out (*est* in the SPEC); the built-in value is then used and
    /// reported.
    Estimable,
    /// The file may leave it out; the model then uses its own default.
    Optional,
    /// The file may leave it out; the reference truck's value is then used without a word:
    /// a neutral value (a scale of 1, a damping of 0) that leaves the file's other values as
    /// they are.
    Neutral,
}

/// The declared parameters that have a key of their own in a section (the key comes from the
/// declaration, [`Field::location`]), with how they stand in the file and the comment written
/// beside them. The reader and the writer loop over this table; a new parameter of a fixed
/// section is a row here, its declaration in [`crate::params`] and its field in the structs
/// above.
const DECLARED_KEYS: &[(Field, Presence, &str)] = &[
    (Field::LeverCompliance, Presence::Required, "k_scl"),
    (Field::Unsprung, Presence::Estimable, "m2 (est)"),
    (Field::LeverInertia, Presence::Estimable, "I_g (est)"),
    (Field::TireStiffness, Presence::Required, "k_w"),
    (
        Field::TireDamping,
        Presence::Neutral,
        "c_w: tire damping, 0 = the thesis' tire",
    ),
    (Field::HingeFriction, Presence::Estimable, "k_f (est)"),
    (
        Field::DamperScale,
        Presence::Neutral,
        "dscl: every force of the table times this",
    ),
    (Field::SlowForceScale, Presence::Optional, "k_sd (est)"),
    (
        Field::CreepStiffness,
        Presence::Optional,
        "m2xh creep stiffness k_sd (est)",
    ),
    (
        Field::CreepTimeConstant,
        Presence::Optional,
        "m2xh creep time constant (est)",
    ),
    (Field::WallCreepStiffness, Presence::Optional, "kc"),
    (Field::WallCreepTime, Presence::Optional, "tc"),
    (Field::WallFrictionForce, Presence::Optional, "fc"),
    (Field::WallFrictionStiffness, Presence::Optional, "kdahl"),
    (Field::GasThermalTime, Presence::Optional, "tth"),
    (Field::LineResistance, Presence::Optional, "rline"),
];

/// The written entries of `section`'s declared keys that have a value.
fn declared_entries(p: &TruckParameters, section: &str) -> Vec<TomlEntry> {
    DECLARED_KEYS
        .iter()
        .filter(|(field, _, _)| field.location().0 == section)
        .filter_map(|&(field, _, comment)| {
            let value = get(p, field);
            (!value.is_nan()).then(|| (field.location().1, format!("{value:?}"), comment))
        })
        .collect()
}

/// The keys of every section but the declared parameters' (see [`schema`]).
const BASE_SCHEMA: &[TableSchema] = &[
    TableSchema {
        name: "",
        keys: &[
            "environment",
            "geometry",
            "mass",
            "tire",
            "damper",
            "bellow",
            "valve",
            "slow_dynamics",
            "model3",
            "effects",
        ],
    },
    TableSchema {
        name: "environment",
        keys: &[
            "gravity_m_s2",
            "gas_constant_j_mol_k",
            "temperature_k",
            "ambient_pressure_kpa",
        ],
    },
    TableSchema {
        name: "geometry",
        keys: &["h0_m", "l1_m", "l2_m", "l3_m"],
    },
    TableSchema {
        name: "mass",
        keys: &[],
    },
    TableSchema {
        name: "tire",
        keys: &[],
    },
    TableSchema {
        name: "damper",
        keys: &["velocity_m_s", "force_n", "correction"],
    },
    TableSchema {
        name: "bellow",
        keys: &[
            "effective_area_poly_m2",
            "cross_section_m2",
            // Tagged law tables (`[bellow.effective_area]`, `[bellow.gas_volume]`), and
            // `[valve]`, check their keys by their law (`crate::laws`).
            "effective_area",
            "gas_volume",
        ],
    },
    TableSchema {
        name: "effects",
        keys: &[],
    },
    TableSchema {
        name: "slow_dynamics",
        keys: &["oe_b", "oe_f", "oe_nk", "oe_sample_time_s"],
    },
    TableSchema {
        name: "model3",
        keys: &[
            "oe_load_b",
            "oe_load_f",
            "oe_load_nk",
            "oe_pressure_b",
            "oe_pressure_f",
            "oe_pressure_nk",
            "oe_sample_time_s",
        ],
    },
];

/// Every section's keys: [`BASE_SCHEMA`] plus the declared parameters' keys
/// ([`DECLARED_KEYS`]), so a declared key is valid where its declaration puts it.
fn schema() -> &'static [TableSchema] {
    static KEYS: LazyLock<Vec<Vec<&'static str>>> = LazyLock::new(|| {
        BASE_SCHEMA
            .iter()
            .map(|table| {
                let declared = DECLARED_KEYS
                    .iter()
                    .map(|(field, _, _)| field.location())
                    .filter(|(section, _, _)| *section == table.name)
                    .map(|(_, key, _)| key);
                table.keys.iter().copied().chain(declared).collect()
            })
            .collect()
    });
    static SCHEMA: LazyLock<Vec<TableSchema>> = LazyLock::new(|| {
        BASE_SCHEMA
            .iter()
            .zip(KEYS.iter())
            .map(|(table, keys)| TableSchema {
                name: table.name,
                keys: keys.as_slice(),
            })
            .collect()
    });
    &SCHEMA
}

#[derive(Deserialize)]
struct FileEnvironment {
    gravity_m_s2: Option<f64>,
    gas_constant_j_mol_k: Option<f64>,
    temperature_k: Option<f64>,
    ambient_pressure_kpa: Option<f64>,
}

#[derive(Deserialize)]
struct FileGeometry {
    h0_m: Option<f64>,
    l1_m: Option<f64>,
    l2_m: Option<f64>,
    l3_m: Option<f64>,
}

#[derive(Deserialize)]
struct FileDamper {
    velocity_m_s: Option<Vec<f64>>,
    force_n: Option<Vec<f64>>,
    correction: Option<Vec<f64>>,
}

#[derive(Deserialize, Default)]
struct FileBellow {
    effective_area_poly_m2: Option<Vec<f64>>,
    cross_section_m2: Option<Vec<f64>>,
    effective_area: Option<toml::Table>,
    gas_volume: Option<toml::Table>,
}

#[derive(Deserialize)]
struct FileSlow {
    oe_b: Option<Vec<f64>>,
    oe_f: Option<Vec<f64>>,
    oe_nk: Option<i64>,
    oe_sample_time_s: Option<f64>,
}

#[derive(Deserialize)]
struct FileModel3 {
    oe_load_b: Option<Vec<f64>>,
    oe_load_f: Option<Vec<f64>>,
    oe_load_nk: Option<i64>,
    oe_pressure_b: Option<Vec<f64>>,
    oe_pressure_f: Option<Vec<f64>>,
    oe_pressure_nk: Option<i64>,
    oe_sample_time_s: Option<f64>,
}

#[derive(Deserialize)]
struct TruckFile {
    environment: Option<FileEnvironment>,
    geometry: Option<FileGeometry>,

    damper: Option<FileDamper>,
    bellow: Option<FileBellow>,
    /// Read by its law ([`ValveFlowLaw`]), from the parsed table.
    valve: Option<toml::Table>,
    slow_dynamics: Option<FileSlow>,
    model3: Option<FileModel3>,
}

/// Reads and checks a truck parameter file.
pub fn read_truck(path: &Path) -> Result<LoadedTruck, DataError> {
    let text = std::fs::read_to_string(path).map_err(|e| DataError::io(path, e))?;
    parse_truck(&text, path)
}

/// Parses truck-file text; `path` names the source in errors.
pub fn parse_truck(text: &str, path: &Path) -> Result<LoadedTruck, DataError> {
    let table = parse_toml(text, path)?;
    check_keys(&table, schema(), text, path)?;
    check_finite(&table, text, path)?;
    let file: TruckFile = deserialize(text, path)?;
    let mut ctx = Ctx {
        text,
        path,
        defaulted: Vec::new(),
    };
    let reference = TruckParameters::reference();

    let env = file
        .environment
        .ok_or_else(|| ctx.missing_section("environment"))?;
    let environment = Environment {
        gravity_m_s2: ctx.required(
            "environment",
            "gravity_m_s2",
            env.gravity_m_s2,
            9.0..=10.5,
            "m/s²",
        )?,
        gas_constant_j_mol_k: ctx.required(
            "environment",
            "gas_constant_j_mol_k",
            env.gas_constant_j_mol_k,
            8.2..=8.4,
            "J/(mol K)",
        )?,
        temperature_k: ctx.required(
            "environment",
            "temperature_k",
            env.temperature_k,
            200.0..=400.0,
            "K (not °C)",
        )?,
        ambient_pressure_pa: ctx.required(
            "environment",
            "ambient_pressure_kpa",
            env.ambient_pressure_kpa,
            50.0..=120.0,
            "kPa absolute",
        )? * PA_PER_KPA,
    };

    let geo = file
        .geometry
        .ok_or_else(|| ctx.missing_section("geometry"))?;
    let geometry = Geometry {
        h0_m: ctx.required("geometry", "h0_m", geo.h0_m, -1.0..=1.0, "m")?,
        l1_m: ctx.required("geometry", "l1_m", geo.l1_m, 0.05..=3.0, "m")?,
        l2_m: ctx.required("geometry", "l2_m", geo.l2_m, 0.0..=3.0, "m")?,
        l3_m: ctx.required("geometry", "l3_m", geo.l3_m, -3.0..=3.0, "m")?,
        // Declared keys are read below, from their declarations.
        lever_compliance_m_per_n: reference.geometry.lever_compliance_m_per_n,
    };

    if !table.contains_key("tire") {
        return Err(ctx.missing_section("tire"));
    }

    let damper_file = file.damper.ok_or_else(|| ctx.missing_section("damper"))?;
    let damper = ctx.damper(damper_file)?;

    let bellow_file = file.bellow.unwrap_or_default();
    let effective_area = match (
        bellow_file.effective_area_poly_m2,
        &bellow_file.effective_area,
    ) {
        (Some(_), Some(_)) => {
            return Err(ctx.given_twice("effective_area_poly_m2", "effective_area"));
        }
        (None, Some(table)) => {
            EffectiveAreaLaw::from_table(&ctx.law_table("bellow.effective_area", table))?
        }
        (poly, None) => {
            let poly: [f64; 5] = ctx.estimable_array(
                "bellow",
                "effective_area_poly_m2",
                poly,
                REFERENCE_AREA_POLY_M2,
            )?;
            for (i, &value) in poly.iter().enumerate() {
                ctx.check_param(Field::EffectiveArea(i), value)?;
            }
            EffectiveAreaLaw::polynomial(poly)
        }
    };
    let gas_volume = match (bellow_file.cross_section_m2, &bellow_file.gas_volume) {
        (Some(_), Some(_)) => return Err(ctx.given_twice("cross_section_m2", "gas_volume")),
        (None, Some(table)) => {
            GasVolumeLaw::from_table(&ctx.law_table("bellow.gas_volume", table))?
        }
        (cross, None) => {
            let cross: [f64; 2] = ctx.estimable_array(
                "bellow",
                "cross_section_m2",
                cross,
                *GasVolumeLaw::REFERENCE_CROSS_SECTION_M2,
            )?;
            for (i, &value) in cross.iter().enumerate() {
                ctx.check_param(Field::CrossSection(i), value)?;
            }
            GasVolumeLaw::cross_section(cross)
        }
    };
    let area_key = match bellow_file.effective_area {
        Some(_) => ("bellow.effective_area", "coefficients_m2"),
        None => ("bellow", "effective_area_poly_m2"),
    };
    let volume_key = match (&bellow_file.gas_volume, &gas_volume) {
        (Some(_), GasVolumeLaw::AreaIntegral { .. }) => ("bellow.gas_volume", "dead_volume_m3"),
        (Some(_), _) => ("bellow.gas_volume", "coefficients_m2"),
        (None, _) => ("bellow", "cross_section_m2"),
    };
    ctx.check_areas(&effective_area, area_key, &gas_volume, volume_key)?;
    let bellow = BellowParameters {
        effective_area,
        gas_volume,
        hinge_friction_n_s_per_m: reference.bellow.hinge_friction_n_s_per_m,
    };

    let valve = match &file.valve {
        Some(table) if table.contains_key("law") => {
            ValveFlowLaw::from_table(&ctx.law_table("valve", table))?
        }
        // The SPEC's form: the thesis' resistances, each estimable.
        table => {
            let empty = toml::Table::new();
            let table = table.as_ref().unwrap_or(&empty);
            let law_table = LawTable {
                section: "valve",
                table,
                text,
                path,
            };
            law_table.check_keys(ValveFlowLaw::LAWS[0].keys, ValveFlowLaw::LAWS[0].tag)?;
            let mut valve = reference.valve;
            for field in valve.fields() {
                let (_, key, _) = field.location();
                let given = law_table.optional_number(key)?;
                let value = ctx.estimable_param(field, given, get(&reference, field))?;
                valve.set(field, value);
            }
            valve
        }
    };

    let slow_dynamics = match file.slow_dynamics {
        None => SlowDynamics::default(),
        Some(s) => ctx.slow_dynamics(s)?,
    };
    let model3 = match file.model3 {
        None => Model3Oe::default(),
        Some(m) => ctx.model3(m)?,
    };

    let mut parameters = TruckParameters {
        environment,
        geometry,
        mass: reference.mass.clone(),
        tire: reference.tire.clone(),
        damper,
        bellow,
        valve,
        valve_law_named: matches!(valve, ValveFlowLaw::LinearResistance { .. })
            && file.valve.as_ref().is_some_and(|t| t.contains_key("law")),
        slow_dynamics,
        model3,
        effects: EffectValues::default(),
    };
    // Every declared key, from its declaration: range-checked, defaulted or required as the
    // table says. The lever inertia's default follows the masses read before it.
    for &(field, presence, _) in DECLARED_KEYS {
        let (section, key, _) = field.location();
        let given = ctx.declared_number(&table, section, key)?;
        let value = match presence {
            Presence::Required => Some(ctx.required_param(field, given)?),
            Presence::Estimable => {
                let default = match field {
                    Field::LeverInertia => {
                        let l1 = parameters.geometry.l1_m;
                        parameters.mass.unsprung_kg * l1 * l1
                    }
                    _ => get(&reference, field),
                };
                Some(ctx.estimable_param(field, given, default)?)
            }
            Presence::Optional => given.map(|v| ctx.check_param(field, v)).transpose()?,
            Presence::Neutral => Some(match given {
                Some(v) => ctx.check_param(field, v)?,
                None => get(&reference, field),
            }),
        };
        if let Some(value) = value {
            set(&mut parameters, field, value);
        }
    }

    // Reported in the file's section order.
    let sections = BASE_SCHEMA[0].keys;
    let mut defaulted = ctx.defaulted;
    defaulted.sort_by_key(|d| {
        let section = d.key.split('.').next().unwrap_or_default();
        sections.iter().position(|s| *s == section)
    });
    Ok(LoadedTruck {
        parameters,
        defaulted,
    })
}

struct Ctx<'a> {
    text: &'a str,
    path: &'a Path,
    defaulted: Vec<DefaultedKey>,
}

impl Ctx<'_> {
    fn location(&self, section: &str, key: &str) -> Location {
        let mut loc = Location::file(self.path);
        if let Some(line) = find_key_line(self.text, section, key) {
            loc = loc.line(line);
        }
        loc
    }

    fn missing_section(&self, section: &str) -> DataError {
        DataError::new(
            Location::file(self.path),
            DataErrorKind::MissingKey {
                key: format!("[{section}]"),
                expected: "this section is required (see SPEC §5)".to_owned(),
            },
        )
    }

    fn invalid(&self, section: &str, key: &str, value: impl ToString, reason: String) -> DataError {
        DataError::new(
            self.location(section, key),
            DataErrorKind::InvalidValue {
                key: format!("{section}.{key}"),
                value: value.to_string(),
                reason,
            },
        )
    }

    fn check_range(
        &self,
        section: &str,
        key: &str,
        value: f64,
        range: std::ops::RangeInclusive<f64>,
        unit: &str,
    ) -> Result<f64, DataError> {
        if range.contains(&value) {
            Ok(value)
        } else {
            Err(self.invalid(
                section,
                key,
                value,
                format!(
                    "outside the plausible range {} to {} {unit}; check the unit",
                    range.start(),
                    range.end()
                ),
            ))
        }
    }

    /// `value` against the declared range of `field` ([`crate::params`]); the error names the
    /// key (with the index for an array element), the value and the range.
    fn check_param(&self, field: Field, value: f64) -> Result<f64, DataError> {
        let (section, key, index) = field.location();
        check_declared(
            self.location(section, key),
            section,
            key,
            index,
            field,
            value,
        )
    }

    fn required_param(&self, field: Field, value: Option<f64>) -> Result<f64, DataError> {
        let (section, key, _) = field.location();
        let unit = field.param().info.unit;
        let value = self.required(section, key, value, f64::NEG_INFINITY..=f64::INFINITY, unit)?;
        self.check_param(field, value)
    }

    /// A value the file may leave out: checked when the file gives it; otherwise `default`,
    /// recorded as defaulted (a default is never refused: it is not the user's to fix).
    fn estimable_param(
        &mut self,
        field: Field,
        value: Option<f64>,
        default: f64,
    ) -> Result<f64, DataError> {
        match value {
            Some(v) => self.check_param(field, v),
            None => {
                let (section, key, _) = field.location();
                self.defaulted.push(DefaultedKey {
                    key: format!("{section}.{key}"),
                    value: format!("{default:?}"),
                });
                Ok(default)
            }
        }
    }

    fn required(
        &self,
        section: &str,
        key: &str,
        value: Option<f64>,
        range: std::ops::RangeInclusive<f64>,
        unit: &str,
    ) -> Result<f64, DataError> {
        let value = value.ok_or_else(|| {
            DataError::new(
                self.location(section, section),
                DataErrorKind::MissingKey {
                    key: format!("{section}.{key}"),
                    expected: format!(
                        "a number in {unit}; only keys the pipeline estimates may be omitted"
                    ),
                },
            )
        })?;
        self.check_range(section, key, value, range, unit)
    }

    fn estimable_array<const N: usize>(
        &mut self,
        section: &str,
        key: &str,
        value: Option<Vec<f64>>,
        default: [f64; N],
    ) -> Result<[f64; N], DataError> {
        match value {
            Some(v) => {
                let len = v.len();
                <[f64; N]>::try_from(v).map_err(|_| {
                    self.invalid(
                        section,
                        key,
                        format!("[{len} values]"),
                        format!("expected exactly {N} values"),
                    )
                })
            }
            None => {
                self.defaulted.push(DefaultedKey {
                    key: format!("{section}.{key}"),
                    value: format!("{default:?}"),
                });
                Ok(default)
            }
        }
    }

    fn damper(&self, file: FileDamper) -> Result<DamperTable, DataError> {
        let velocity = file.velocity_m_s.ok_or_else(|| {
            DataError::new(
                self.location("damper", "damper"),
                DataErrorKind::MissingKey {
                    key: "damper.velocity_m_s".to_owned(),
                    expected: "an array of extension velocities in m/s".to_owned(),
                },
            )
        })?;
        let force = file.force_n.ok_or_else(|| {
            DataError::new(
                self.location("damper", "damper"),
                DataErrorKind::MissingKey {
                    key: "damper.force_n".to_owned(),
                    expected: "an array of forces in N, one per velocity".to_owned(),
                },
            )
        })?;
        if velocity.len() < 2 || velocity.len() != force.len() {
            return Err(self.invalid(
                "damper",
                "force_n",
                format!("[{} values]", force.len()),
                format!(
                    "the table needs at least 2 points and one force per velocity ({} velocities)",
                    velocity.len()
                ),
            ));
        }
        if let Some(i) = velocity.windows(2).position(|w| w[1] <= w[0]) {
            return Err(self.invalid(
                "damper",
                "velocity_m_s",
                velocity[i + 1],
                format!(
                    "velocities must increase strictly (entry {} follows {})",
                    i + 2,
                    velocity[i]
                ),
            ));
        }
        let correction = file.correction.unwrap_or_default();
        if !correction.is_empty() {
            let points = velocity.len();
            if correction.len() != points || points > crate::params::MAX_DAMPER_CORRECTIONS {
                return Err(self.invalid(
                    "damper",
                    "correction",
                    format!("[{} values]", correction.len()),
                    format!(
                        "one factor per table point ({points}), for a table of at most {} points",
                        crate::params::MAX_DAMPER_CORRECTIONS
                    ),
                ));
            }
            for (i, &value) in correction.iter().enumerate() {
                self.check_param(Field::DamperCorrection(i), value)?;
            }
        }
        // The scale is a declared key (`DECLARED_KEYS`), read after the table.
        Ok(DamperTable {
            correction,
            ..DamperTable::new(velocity, force)
        })
    }

    /// An area law that is not positive anywhere over the reference bellow's stroke
    /// (0.2–0.45 m) is broken; thesis Table 5.2's `p1 = 0.08362` is the known example.
    /// `area_key`, `volume_key`: where the file gave each law (section, key).
    fn check_areas(
        &self,
        area: &EffectiveAreaLaw,
        (section, key): (&str, &str),
        volume: &GasVolumeLaw,
        (volume_section, volume_key): (&str, &str),
    ) -> Result<(), DataError> {
        let heights = (0..=25).map(|i| 0.2 + 0.01 * f64::from(i));
        if heights.clone().all(|h| area.area_m2(h, 0.0) <= 0.0) {
            return Err(self.invalid(
                section,
                key,
                match area.coefficients_m2() {
                    Some(c) => format!("{c:?}"),
                    None => format!("law {:?}", area.tag()),
                },
                "the effective area is not positive anywhere between 0.2 and 0.45 m bellow height (thesis Table 5.2 misprints p1 = 0.08362; the correct value is 0.8362)".to_owned(),
            ));
        }
        if heights
            .clone()
            .all(|h| volume.cross_section_m2(area, h) <= 0.0)
        {
            let (given, reason) = match volume {
                GasVolumeLaw::CrossSection { coefficients_m2 } => (
                    format!("{coefficients_m2:?}"),
                    "the cross-section A0 + A1 h is not positive anywhere between 0.2 and 0.45 m",
                ),
                GasVolumeLaw::AreaIntegral { dead_volume_m3, .. } => (
                    format!("{dead_volume_m3:?}"),
                    "the gas volume (dead volume plus the swept effective area) is not positive anywhere between 0.2 and 0.45 m",
                ),
            };
            return Err(self.invalid(volume_section, volume_key, given, reason.to_owned()));
        }
        Ok(())
    }

    /// The number at `section.key`, if the file gives one.
    fn declared_number(
        &self,
        table: &toml::Table,
        section: &str,
        key: &str,
    ) -> Result<Option<f64>, DataError> {
        let value = match table.get(section) {
            None => None,
            Some(toml::Value::Table(t)) => t.get(key),
            Some(other) => {
                // A top-level key, or a `[section]` header whose value is not a table.
                let mut loc = Location::file(self.path);
                if let Some(line) = find_key_line(self.text, "", section) {
                    loc = loc.line(line);
                }
                return Err(DataError::new(
                    loc,
                    DataErrorKind::InvalidValue {
                        key: section.to_owned(),
                        value: other.to_string(),
                        reason: format!("expected a section `[{section}]` of keys"),
                    },
                ));
            }
        };
        match value {
            None => Ok(None),
            Some(toml::Value::Float(f)) => Ok(Some(*f)),
            Some(toml::Value::Integer(i)) => Ok(Some(*i as f64)),
            Some(other) => Err(self.invalid(section, key, other, "expected a number".to_owned())),
        }
    }

    /// A law given both in the SPEC's form and as a tagged table.
    fn given_twice(&self, spec_key: &str, table: &str) -> DataError {
        self.invalid(
            "bellow",
            table,
            format!("[bellow.{table}]"),
            format!("the law is also given as `bellow.{spec_key}`; give it once, either way"),
        )
    }

    fn law_table<'t>(&'t self, section: &'t str, table: &'t toml::Table) -> LawTable<'t> {
        LawTable {
            section,
            table,
            text: self.text,
            path: self.path,
        }
    }

    fn slow_dynamics(&self, s: FileSlow) -> Result<SlowDynamics, DataError> {
        let d = SlowDynamics::default();
        let oe_nk = match s.oe_nk {
            None => d.oe_nk,
            Some(nk) if (0..=1000).contains(&nk) => nk as usize,
            Some(nk) => {
                return Err(self.invalid(
                    "slow_dynamics",
                    "oe_nk",
                    nk,
                    "expected a delay of 0 to 1000 samples".to_owned(),
                ));
            }
        };
        let oe_sample_time_s = match s.oe_sample_time_s {
            None => d.oe_sample_time_s,
            Some(ts) => {
                self.check_range("slow_dynamics", "oe_sample_time_s", ts, 1e-4..=100.0, "s")?
            }
        };
        let oe_b = s.oe_b.unwrap_or(d.oe_b);
        if oe_b.is_empty() {
            return Err(self.invalid(
                "slow_dynamics",
                "oe_b",
                "[]",
                "expected at least one numerator coefficient".to_owned(),
            ));
        }
        Ok(SlowDynamics {
            oe_b,
            oe_f: s.oe_f.unwrap_or(d.oe_f),
            oe_nk,
            oe_sample_time_s,
            // Declared keys, read from their declarations in `parse_truck`.
            force_scale: None,
            creep_stiffness_n_per_m: None,
            creep_time_constant_s: None,
        })
    }

    fn model3(&self, m: FileModel3) -> Result<Model3Oe, DataError> {
        let d = Model3Oe::default();
        let nk = |key: &str, value: Option<i64>, default: usize| match value {
            None => Ok(default),
            Some(nk) if (0..=1000).contains(&nk) => Ok(nk as usize),
            Some(nk) => Err(self.invalid(
                "model3",
                key,
                nk,
                "expected a delay of 0 to 1000 samples".to_owned(),
            )),
        };
        let load_nk = nk("oe_load_nk", m.oe_load_nk, d.load_nk)?;
        let pressure_nk = nk("oe_pressure_nk", m.oe_pressure_nk, d.pressure_nk)?;
        let sample_time_s = match m.oe_sample_time_s {
            None => d.sample_time_s,
            Some(ts) => self.check_range("model3", "oe_sample_time_s", ts, 1e-4..=100.0, "s")?,
        };
        let load_b = m.oe_load_b.unwrap_or(d.load_b);
        let pressure_b = m.oe_pressure_b.unwrap_or(d.pressure_b);
        for (key, b) in [("oe_load_b", &load_b), ("oe_pressure_b", &pressure_b)] {
            if b.is_empty() {
                return Err(self.invalid(
                    "model3",
                    key,
                    "[]",
                    "expected at least one numerator coefficient".to_owned(),
                ));
            }
        }
        Ok(Model3Oe {
            load_b,
            load_f: m.oe_load_f.unwrap_or(d.load_f),
            load_nk,
            pressure_b,
            pressure_f: m.oe_pressure_f.unwrap_or(d.pressure_f),
            pressure_nk,
            sample_time_s,
        })
    }
}

/// `(key, value as TOML, comment)`.
type TomlEntry = (&'static str, String, &'static str);
/// `(section name, section comment, entries)`.
type TomlSection = (&'static str, &'static str, Vec<TomlEntry>);

/// The parameters as a truck file, with units and *est* marks in comments. Numbers are written
/// in shortest round-trip form, so the text loads back to identical values.
pub fn truck_to_toml(p: &TruckParameters) -> String {
    // `{:?}` on f64 (and on arrays of f64) is Rust's shortest round-trip form and always a
    // valid TOML float.
    let f = |v: f64| format!("{v:?}");
    let e = &p.environment;
    let g = &p.geometry;
    let sd = &p.slow_dynamics;
    // A thesis law is written in the SPEC's form, any other as a tagged table.
    let mut bellow_entries: Vec<TomlEntry> = Vec::new();
    let mut law_tables: Vec<TomlSection> = Vec::new();
    let law_header = |tag: &'static str| ("law", format!("{tag:?}"), "");
    match (
        p.bellow.effective_area.tagged_entries(),
        p.bellow.effective_area.coefficients_m2(),
    ) {
        (None, Some(coefficients)) => bellow_entries.push((
            "effective_area_poly_m2",
            format!("{coefficients:?}"),
            "p0..p4 (est)",
        )),
        (entries, _) => law_tables.push((
            "bellow.effective_area",
            "effective-area law",
            std::iter::once(law_header(p.bellow.effective_area.tag()))
                .chain(entries.into_iter().flatten())
                .collect(),
        )),
    }
    // The thesis' law in the SPEC's form; any other as its tagged table (never nothing: a
    // law without entries still writes its tag).
    match (
        p.bellow.gas_volume.tagged_entries(),
        p.bellow.gas_volume.coefficients_m2(),
    ) {
        (None, Some(coefficients)) => bellow_entries.push((
            "cross_section_m2",
            format!("{coefficients:?}"),
            "A0, A1 (est)",
        )),
        (entries, _) => law_tables.push((
            "bellow.gas_volume",
            "gas-volume law",
            std::iter::once(law_header(p.bellow.gas_volume.tag()))
                .chain(entries.into_iter().flatten())
                .collect(),
        )),
    }
    bellow_entries.extend(declared_entries(p, "bellow"));
    let valve_entries: Vec<TomlEntry> = match (p.valve.tagged_entries(), &p.valve) {
        (Some(entries), law) => std::iter::once(law_header(law.tag()))
            .chain(entries)
            .collect(),
        (
            None,
            ValveFlowLaw::LinearResistance {
                fill_pa_s_per_mol,
                exhaust_pa_s_per_mol,
            },
        ) => p
            .valve_law_named
            .then(|| law_header(p.valve.tag()))
            .into_iter()
            .chain([
                (
                    "fill_resistance_pa_s_per_mol",
                    f(*fill_pa_s_per_mol),
                    "R_flow1 (est)",
                ),
                (
                    "exhaust_resistance_pa_s_per_mol",
                    f(*exhaust_pa_s_per_mol),
                    "R_flow2 (est)",
                ),
            ])
            .collect(),
        (None, law) => vec![law_header(law.tag())],
    };
    let mut sections: Vec<TomlSection> = vec![
        (
            "environment",
            "",
            vec![
                ("gravity_m_s2", f(e.gravity_m_s2), ""),
                ("gas_constant_j_mol_k", f(e.gas_constant_j_mol_k), ""),
                ("temperature_k", f(e.temperature_k), ""),
                (
                    "ambient_pressure_kpa",
                    f(e.ambient_pressure_pa / PA_PER_KPA),
                    "absolute",
                ),
            ],
        ),
        (
            "geometry",
            "",
            vec![
                ("h0_m", f(g.h0_m), "chassis bottom to hinge"),
                ("l1_m", f(g.l1_m), "hinge to axle"),
                ("l2_m", f(g.l2_m), "axle to bellow centre"),
                ("l3_m", f(g.l3_m), "axle to damper"),
            ]
            .into_iter()
            .chain(declared_entries(p, "geometry"))
            .collect(),
        ),
        ("mass", "", declared_entries(p, "mass")),
        ("tire", "", declared_entries(p, "tire")),
        (
            "damper",
            "+ = extension (rebound)",
            [
                ("velocity_m_s", format!("{:?}", p.damper.velocity_m_s), ""),
                ("force_n", format!("{:?}", p.damper.force_n), ""),
            ]
            .into_iter()
            .chain((!p.damper.correction.is_empty()).then(|| {
                (
                    "correction",
                    format!("{:?}", p.damper.correction),
                    "dc0, dc1, ..: each point's force times this",
                )
            }))
            .chain(declared_entries(p, "damper"))
            .collect(),
        ),
        ("bellow", "", bellow_entries),
        ("valve", "", valve_entries),
        (
            "slow_dynamics",
            "Model 2 extended: OE from load to F_ext (thesis Table 5.5)",
            vec![
                ("oe_b", format!("{:?}", sd.oe_b), ""),
                ("oe_f", format!("{:?}", sd.oe_f), ""),
                ("oe_nk", sd.oe_nk.to_string(), "samples"),
                ("oe_sample_time_s", f(sd.oe_sample_time_s), ""),
            ]
            .into_iter()
            .chain(declared_entries(p, "slow_dynamics"))
            .collect(),
        ),
    ];
    let m3 = &p.model3;
    let model3 = (
        "model3",
        "Model 3: OE from load (kg) and pressure (kPa gauge) to bellow height (mm), thesis Tables 5.6-5.8",
        vec![
            ("oe_load_b", format!("{:?}", m3.load_b), ""),
            ("oe_load_f", format!("{:?}", m3.load_f), ""),
            ("oe_load_nk", m3.load_nk.to_string(), "samples"),
            ("oe_pressure_b", format!("{:?}", m3.pressure_b), ""),
            ("oe_pressure_f", format!("{:?}", m3.pressure_f), ""),
            ("oe_pressure_nk", m3.pressure_nk.to_string(), "samples"),
            ("oe_sample_time_s", f(m3.sample_time_s), ""),
        ],
    );
    let mut s = String::new();
    // The law tables go right after `[bellow]` and `[valve]`; `[slow_dynamics]` stays last,
    // its optional keys follow below.
    let after_valve = sections
        .iter()
        .position(|(n, _, _)| *n == "valve")
        .map_or(0, |i| i + 1);
    sections.splice(after_valve..after_valve, law_tables);
    for (name, comment, entries) in sections {
        if !s.is_empty() {
            s.push('\n');
        }
        let _ = match comment {
            "" => writeln!(s, "[{name}]"),
            c => writeln!(s, "[{name}]  # {c}"),
        };
        write_entries(&mut s, entries);
    }
    if sd.force_scale.is_none() {
        let _ = writeln!(
            s,
            "# force_scale_n_per_m: k_sd (est); omitted = one tenth of the initial bellow force"
        );
    }
    let (name, comment, entries) = model3;
    let _ = writeln!(s, "\n[{name}]  # {comment}");
    write_entries(&mut s, entries);
    // The truck structure's effects (ours): written only when a value is set, so files of
    // the thesis' models stay as the SPEC shows them. The same holds for `[slow_dynamics]`'s
    // optional keys.
    let effects = declared_entries(p, "effects");
    if !effects.is_empty() {
        let _ = writeln!(
            s,
            "\n[effects]  # the truck structure's wall, gas and supply line"
        );
        write_entries(&mut s, effects);
    }
    s
}

/// `key = value  # comment` lines, the comments aligned (over the lines that have one: a
/// long table without a comment does not push the others' far out).
fn write_entries(s: &mut String, entries: Vec<TomlEntry>) {
    let width = entries
        .iter()
        .filter(|(_, _, c)| !c.is_empty())
        .map(|(k, v, _)| k.len() + v.len() + 3)
        .max()
        .unwrap_or(0);
    for (key, value, comment) in entries {
        let line = format!("{key} = {value}");
        let _ = match comment {
            "" => writeln!(s, "{line}"),
            c => writeln!(s, "{line:width$}  # {c}"),
        };
    }
}

/// Writes a truck file atomically.
pub fn write_truck(path: &Path, p: &TruckParameters) -> Result<(), DataError> {
    write_text_atomically(path, &truck_to_toml(p))
}

#[cfg(test)]
mod tests {
    use super::*;

    const SPEC_EXAMPLE: &str = r#"
[environment]
gravity_m_s2 = 9.81
gas_constant_j_mol_k = 8.314462618
temperature_k = 293.15
ambient_pressure_kpa = 101.325
[geometry]
h0_m = 0.10
l1_m = 0.62
l2_m = 0.28
l3_m = 0.12
lever_compliance_m_per_n = 2.0e-7        # k_scl
[mass]
unsprung_kg = 520.0                      # m2 (nominal; est)
lever_inertia_kg_m2 = 200.0              # I_g (est; default m2 * l1^2)
[tire]
stiffness_n_per_m = 1.8e6                # k_w
[damper]                                 # + = extension (rebound)
velocity_m_s = [-1.0, -0.5, -0.1, 0.0, 0.1, 0.5, 1.0]
force_n      = [-6000.0, -4000.0, -1500.0, 0.0, 3000.0, 9000.0, 13000.0]
[bellow]
effective_area_poly_m2 = [-0.0289, 0.8362, -3.0698, 4.9616, -2.9941]   # est
cross_section_m2 = [0.250, -0.0310]                                     # est
hinge_friction_n_s_per_m = 0.1                                          # k_f (est)
[valve]
fill_resistance_pa_s_per_mol = 2.5e6     # R_flow1 (est)
exhaust_resistance_pa_s_per_mol = 1.5e6  # R_flow2 (est)
"#;

    fn parse(text: &str) -> Result<LoadedTruck, DataError> {
        parse_truck(text, Path::new("truck.toml"))
    }

    #[test]
    fn spec_example_loads_as_the_reference_truck() {
        let loaded = parse(SPEC_EXAMPLE).unwrap();
        assert_eq!(loaded.parameters, TruckParameters::reference());
        assert!(loaded.defaulted.is_empty());
    }

    #[test]
    fn builtin_toml_loads_back_unchanged() {
        let reference = TruckParameters::reference();
        let text = truck_to_toml(&reference);
        let loaded = parse(&text).unwrap();
        assert_eq!(loaded.parameters, reference);
        assert_eq!(truck_to_toml(&loaded.parameters), text);
    }

    #[test]
    fn omitted_estimable_keys_are_reported_with_the_values_used() {
        let text = SPEC_EXAMPLE
            .replace(
                "lever_inertia_kg_m2 = 200.0              # I_g (est; default m2 * l1^2)\n",
                "",
            )
            .replace(
                "fill_resistance_pa_s_per_mol = 2.5e6     # R_flow1 (est)\n",
                "",
            );
        let loaded = parse(&text).unwrap();
        let keys: Vec<_> = loaded.defaulted.iter().map(|d| d.key.as_str()).collect();
        assert_eq!(
            keys,
            [
                "mass.lever_inertia_kg_m2",
                "valve.fill_resistance_pa_s_per_mol"
            ]
        );
        let inertia = loaded.parameters.mass.lever_inertia_kg_m2;
        assert!((inertia - 520.0 * 0.62 * 0.62).abs() < 1e-9);
    }

    #[test]
    fn omitted_required_key_is_an_error() {
        let text = SPEC_EXAMPLE.replace("l2_m = 0.28\n", "");
        let err = parse(&text).unwrap_err();
        assert!(
            err.to_string().contains("missing key `geometry.l2_m`"),
            "{err}"
        );
    }

    #[test]
    fn unknown_key_gets_a_suggestion_and_line() {
        let text = SPEC_EXAMPLE.replace("l3_m = 0.12", "l3_mm = 0.12");
        let err = parse(&text).unwrap_err();
        assert_eq!(err.location.line, Some(11));
        assert!(
            err.to_string()
                .contains("unknown key `geometry.l3_mm` (did you mean `l3_m`?)"),
            "{err}"
        );
        let err = parse(&format!("{SPEC_EXAMPLE}\n[extras]\na = 1\n")).unwrap_err();
        assert!(matches!(err.kind, DataErrorKind::UnknownKey { .. }));
    }

    #[test]
    fn unit_slips_are_caught_at_load_time() {
        let err = parse(&SPEC_EXAMPLE.replace("h0_m = 0.10", "h0_m = 100.0")).unwrap_err();
        assert_eq!(err.location.line, Some(8));
        assert!(err.to_string().contains("check the unit"), "{err}");
        let err = parse(&SPEC_EXAMPLE.replace("temperature_k = 293.15", "temperature_k = 20.0"))
            .unwrap_err();
        assert!(err.to_string().contains("K (not °C)"), "{err}");
        let err = parse(&SPEC_EXAMPLE.replace(
            "ambient_pressure_kpa = 101.325",
            "ambient_pressure_kpa = 101325.0",
        ))
        .unwrap_err();
        assert!(err.to_string().contains("ambient_pressure_kpa"), "{err}");
    }

    #[test]
    fn thesis_typo_in_p1_is_rejected_with_the_correction() {
        let err = parse(&SPEC_EXAMPLE.replace("0.8362", "0.08362")).unwrap_err();
        assert!(
            err.to_string().contains("the correct value is 0.8362"),
            "{err}"
        );
    }

    #[test]
    fn wrong_type_is_located() {
        let err = parse(
            &SPEC_EXAMPLE.replace("stiffness_n_per_m = 1.8e6", "stiffness_n_per_m = \"stiff\""),
        )
        .unwrap_err();
        assert_eq!(err.location.line, Some(17));
        let text = err.to_string();
        assert!(
            text.contains("tire.stiffness_n_per_m") && text.contains("expected a number"),
            "{text}"
        );
        // A key read through serde is located by the TOML error.
        let err = parse(&SPEC_EXAMPLE.replace("l3_m = 0.12", "l3_m = \"long\"")).unwrap_err();
        assert_eq!(err.location.line, Some(11));
        assert!(matches!(err.kind, DataErrorKind::Toml(_)));
    }

    #[test]
    fn damper_table_must_be_consistent() {
        let err = parse(&SPEC_EXAMPLE.replace(
            "[-1.0, -0.5, -0.1, 0.0, 0.1, 0.5, 1.0]",
            "[-1.0, -0.5, -0.1, 0.0, 0.1, 0.5]",
        ))
        .unwrap_err();
        assert!(err.to_string().contains("one force per velocity"), "{err}");
        let err = parse(&SPEC_EXAMPLE.replace(
            "[-1.0, -0.5, -0.1, 0.0, 0.1, 0.5, 1.0]",
            "[-1.0, -0.5, -0.1, 0.0, 0.1, 0.05, 1.0]",
        ))
        .unwrap_err();
        assert!(err.to_string().contains("increase strictly"), "{err}");
    }

    /// Per-point corrections: one per point, each in its declared range, read and written
    /// back; setting one on a table without them names them all (at 1).
    #[test]
    fn damper_corrections_are_one_per_point_and_round_trip() {
        let velocities = "[-1.0, -0.5, -0.1, 0.0, 0.1, 0.5, 1.0]";
        let with = |correction: &str| {
            SPEC_EXAMPLE.replace(
                &format!("velocity_m_s = {velocities}"),
                &format!("velocity_m_s = {velocities}\ncorrection = {correction}"),
            )
        };
        let loaded = parse(&with("[1.0, 1.0, 0.8, 1.0, 1.2, 1.0, 1.0]")).unwrap();
        let damper = &loaded.parameters.damper;
        assert_eq!(damper.correction[4], 1.2);
        assert_eq!(damper.corrected_force_n(4), damper.force_n[4] * 1.2);
        let again = parse(&truck_to_toml(&loaded.parameters)).unwrap();
        assert_eq!(again.parameters.damper, *damper);
        let err = parse(&with("[1.0, 1.0]")).unwrap_err().to_string();
        assert!(
            err.contains("damper.correction") && err.contains("one factor per table point (7)"),
            "{err}"
        );
        let err = parse(&with("[1.0, 1.0, 0.8, 1.0, 9.0, 1.0, 1.0]"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("damper.correction[4]"), "{err}");

        let mut truck = parse(SPEC_EXAMPLE).unwrap().parameters;
        assert!(truck.damper.correction.is_empty());
        assert!(get(&truck, Field::DamperCorrection(2)).is_nan());
        assert!(set(&mut truck, Field::DamperCorrection(2), 0.7));
        assert_eq!(
            truck.damper.correction,
            vec![1.0, 1.0, 0.7, 1.0, 1.0, 1.0, 1.0]
        );
        assert!(!set(&mut truck, Field::DamperCorrection(7), 0.7));
    }

    #[test]
    fn damper_scale_defaults_to_one_silently_is_range_checked_and_round_trips() {
        let loaded = parse(SPEC_EXAMPLE).unwrap();
        assert_eq!(loaded.parameters.damper.scale, 1.0);
        assert!(
            loaded
                .defaulted
                .iter()
                .all(|d| !d.key.starts_with("damper")),
            "{:?}",
            loaded.defaulted
        );
        let scaled = SPEC_EXAMPLE.replace("13000.0]\n", "13000.0]\nscale = 1.2\n");
        assert_ne!(
            scaled, SPEC_EXAMPLE,
            "the example's damper table ends differently"
        );
        let loaded = parse(&scaled).unwrap();
        assert_eq!(loaded.parameters.damper.scale, 1.2);
        let text = truck_to_toml(&loaded.parameters);
        assert_eq!(parse(&text).unwrap().parameters, loaded.parameters);
        let err = parse(&scaled.replace("scale = 1.2", "scale = -1.0")).unwrap_err();
        assert!(err.to_string().contains("damper.scale"), "{err}");
        assert_eq!(err.location.line, find_key_line(&scaled, "damper", "scale"));
    }

    #[test]
    fn tire_damping_defaults_to_zero_silently_is_range_checked_and_round_trips() {
        let loaded = parse(SPEC_EXAMPLE).unwrap();
        assert_eq!(loaded.parameters.tire.damping_n_s_per_m, 0.0);
        assert!(
            loaded.defaulted.iter().all(|d| !d.key.starts_with("tire")),
            "{:?}",
            loaded.defaulted
        );
        let damped = SPEC_EXAMPLE.replace(
            "stiffness_n_per_m = 1.8e6                # k_w\n",
            "stiffness_n_per_m = 1.8e6\ndamping_n_s_per_m = 2500.0\n",
        );
        assert_ne!(damped, SPEC_EXAMPLE, "the example's tire reads differently");
        let loaded = parse(&damped).unwrap();
        assert_eq!(loaded.parameters.tire.damping_n_s_per_m, 2500.0);
        let text = truck_to_toml(&loaded.parameters);
        assert!(text.contains("damping_n_s_per_m = 2500.0"), "{text}");
        assert_eq!(parse(&text).unwrap().parameters, loaded.parameters);
        let err = parse(&damped.replace("2500.0", "-1.0")).unwrap_err();
        assert!(err.to_string().contains("tire.damping_n_s_per_m"), "{err}");
        assert_eq!(
            err.location.line,
            find_key_line(&damped, "tire", "damping_n_s_per_m")
        );
    }

    #[test]
    fn nan_and_inf_are_rejected_even_inside_arrays() {
        let err = parse(&SPEC_EXAMPLE.replace("[0.250, -0.0310]", "[0.250, nan]")).unwrap_err();
        assert_eq!(err.location.line, Some(23));
        assert!(err.to_string().contains("bellow.cross_section_m2"), "{err}");
        let err = parse(&SPEC_EXAMPLE.replace("-1500.0, 0.0", "-1500.0, inf")).unwrap_err();
        assert!(
            err.to_string().contains("expected a finite number"),
            "{err}"
        );
    }

    #[test]
    fn wrong_array_length_is_an_error() {
        let err = parse(&SPEC_EXAMPLE.replace(
            "cross_section_m2 = [0.250, -0.0310]",
            "cross_section_m2 = [0.250]",
        ))
        .unwrap_err();
        assert!(err.to_string().contains("exactly 2 values"), "{err}");
    }

    #[test]
    fn model_sections_of_ours_load_and_round_trip() {
        let text = format!(
            "{SPEC_EXAMPLE}\n[slow_dynamics]\ncreep_stiffness_n_per_m = 25000.0\ncreep_time_constant_s = 30.0\n\n[model3]\noe_load_b = [1e-5]\noe_load_f = [-0.9]\noe_pressure_nk = 2\n"
        );
        let p = parse(&text).unwrap().parameters;
        assert_eq!(p.slow_dynamics.creep_stiffness_n_per_m, Some(25_000.0));
        assert_eq!(p.slow_dynamics.creep_time_constant_s, Some(30.0));
        assert_eq!(p.model3.load_b, [1e-5]);
        assert_eq!(p.model3.load_f, [-0.9]);
        assert_eq!(p.model3.pressure_nk, 2);
        assert_eq!(p.model3.pressure_b, Model3Oe::default().pressure_b);
        let again = parse(&truck_to_toml(&p)).unwrap().parameters;
        assert_eq!(again, p);
        // Omitted: the thesis tables.
        let reference = parse(SPEC_EXAMPLE).unwrap().parameters;
        assert_eq!(reference.model3, Model3Oe::default());
        assert_eq!(reference.model3.load_f, [-1.84, 0.8404]);
    }

    /// The SPEC example with the `[bellow]` and `[valve]` sections replaced.
    fn with_laws(bellow_and_valve: &str) -> String {
        let head = SPEC_EXAMPLE.split("[bellow]").next().unwrap();
        format!("{head}{bellow_and_valve}")
    }

    /// `truck.toml:N:` for the first line of `text` that starts with `start`.
    fn at_line(text: &str, start: &str) -> String {
        let n = text.lines().position(|l| l.starts_with(start)).unwrap() + 1;
        format!("truck.toml:{n}:")
    }

    #[test]
    fn the_area_integral_volume_law_loads_checks_its_dead_volume_and_round_trips() {
        let law = |body: &str| {
            with_laws(&format!(
                "[bellow]\nhinge_friction_n_s_per_m = 0.1\n\
                 effective_area_poly_m2 = [-0.0289, 0.8362, -3.0698, 4.9616, -2.9941]\n\
                 [bellow.gas_volume]\nlaw = \"area_integral\"\n{body}"
            ))
        };
        let loaded = parse(&law("dead_volume_m3 = 0.05\n")).unwrap();
        let p = &loaded.parameters;
        assert_eq!(
            p.bellow.gas_volume,
            GasVolumeLaw::AreaIntegral {
                dead_volume_m3: 0.05,
                bellows: 2
            }
        );
        assert_eq!(get(p, Field::DeadVolume), 0.05);
        assert!(get(p, Field::CrossSection(0)).is_nan());
        let written = truck_to_toml(p);
        assert!(
            written.contains("law = \"area_integral\"") && !written.contains("cross_section_m2"),
            "{written}"
        );
        assert_eq!(&parse(&written).unwrap().parameters, p);
        // A dead volume below zero, a missing one, or the other law's key: each an error that
        // names the key.
        let err = parse(&law("dead_volume_m3 = -0.01\n"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("dead_volume_m3"), "{err}");
        let err = parse(&law("")).unwrap_err().to_string();
        assert!(err.contains("dead_volume_m3"), "{err}");
        let err = parse(&law("dead_volume_m3 = 0.05\nbellows = 2.5\n"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("bellows") && err.contains("whole number"),
            "{err}"
        );
        let four = parse(&law("dead_volume_m3 = 0.05\nbellows = 4\n")).unwrap();
        assert!(matches!(
            four.parameters.bellow.gas_volume,
            GasVolumeLaw::AreaIntegral { bellows: 4, .. }
        ));
        let err = parse(&law(
            "dead_volume_m3 = 0.05\ncoefficients_m2 = [0.25, -0.03]\n",
        ))
        .unwrap_err()
        .to_string();
        assert!(err.contains("coefficients_m2"), "{err}");
    }

    #[test]
    fn laws_load_from_tagged_tables_and_round_trip() {
        let text = with_laws(
            "[bellow]\nhinge_friction_n_s_per_m = 0.1\n\
             [bellow.effective_area]\nlaw = \"polynomial_pressure\"\n\
             coefficients_m2 = [-0.0289, 0.8362, -3.0698, 4.9616, -2.9941]\ngrowth_per_100kpa = 0.004\n\
             [bellow.gas_volume]\nlaw = \"cross_section\"\ncoefficients_m2 = [0.262, -0.04]\n\
             [valve]\nlaw = \"orifice\"\nfill_conductance_m3_s_pa = 5e-9\n\
             exhaust_conductance_m3_s_pa = 1.2e-8\ncritical_pressure_ratio = 0.4\n\
             [effects]\nfriction_force_n = 150.0\n",
        );
        let loaded = parse(&text).unwrap();
        let p = &loaded.parameters;
        assert_eq!(
            p.bellow.effective_area,
            EffectiveAreaLaw::PressurePolynomial {
                coefficients_m2: [-0.0289, 0.8362, -3.0698, 4.9616, -2.9941],
                growth_per_100kpa: 0.004
            }
        );
        assert_eq!(p.bellow.gas_volume.coefficients_m2(), Some(&[0.262, -0.04]));
        assert_eq!(p.valve.tag(), "orifice");
        assert_eq!(p.effects.friction_force_n, Some(150.0));
        assert_eq!(p.effects.creep_stiffness_n_per_m, None);
        assert!(loaded.defaulted.is_empty(), "{:?}", loaded.defaulted);
        let written = truck_to_toml(p);
        assert!(written.contains("[bellow.effective_area]"), "{written}");
        assert!(written.contains("law = \"orifice\""), "{written}");
        // The thesis' volume law is written in the SPEC's form.
        assert!(
            written.contains("cross_section_m2 = [0.262, -0.04]"),
            "{written}"
        );
        assert_eq!(&parse(&written).unwrap().parameters, p);
        // The SPEC form is the thesis' laws, and is written as such.
        let spec = parse(SPEC_EXAMPLE).unwrap().parameters;
        assert_eq!(spec.valve.tag(), "linear_resistance");
        assert_eq!(spec.bellow.effective_area.tag(), "polynomial");
        assert!(!truck_to_toml(&spec).contains("law ="));
        // A tagged thesis law loads too.
        let tagged = with_laws(
            "[bellow.effective_area]\nlaw = \"polynomial\"\n\
             coefficients_m2 = [-0.0289, 0.8362, -3.0698, 4.9616, -2.9941]\n\
             [valve]\nlaw = \"linear_resistance\"\nfill_resistance_pa_s_per_mol = 2.5e6\n\
             exhaust_resistance_pa_s_per_mol = 1.5e6\n",
        );
        let t = parse(&tagged).unwrap().parameters;
        assert_eq!(t.bellow.effective_area, spec.bellow.effective_area);
        assert_eq!(t.valve, spec.valve);
        // Named, the linear law is recorded as named (the `truck` structure then runs it) and
        // written with its name; the SPEC form stays unnamed.
        assert!(t.valve_law_named && !spec.valve_law_named);
        let written = truck_to_toml(&t);
        assert!(written.contains("law = \"linear_resistance\""), "{written}");
        assert_eq!(parse(&written).unwrap().parameters, t);
    }

    #[test]
    fn a_section_that_is_not_a_table_is_an_error() {
        let text = SPEC_EXAMPLE.replace(
            "[mass]\nunsprung_kg = 520.0                      # m2 (nominal; est)\nlever_inertia_kg_m2 = 200.0              # I_g (est; default m2 * l1^2)\n",
            "",
        );
        assert!(!text.contains("[mass]"), "the fixture changed");
        let text = format!("mass = 520\n{text}");
        let err = parse(&text).unwrap_err().to_string();
        assert!(err.contains("expected a section `[mass]`"), "{err}");
        assert!(err.starts_with("truck.toml:1:"), "{err}");
    }

    #[test]
    fn a_broken_tagged_volume_law_is_located_in_its_table() {
        let text = with_laws(
            "[bellow.gas_volume]\nlaw = \"cross_section\"\ncoefficients_m2 = [0.01, -1.0]\n",
        );
        let err = parse(&text).unwrap_err().to_string();
        assert!(err.contains("bellow.gas_volume.coefficients_m2"), "{err}");
        assert!(err.starts_with(&at_line(&text, "coefficients_m2")), "{err}");
    }

    #[test]
    fn law_errors_name_the_line_the_key_and_the_choices() {
        let unknown = with_laws("[valve]\nlaw = \"poiseuille\"\n");
        let err = parse(&unknown).unwrap_err().to_string();
        assert!(err.starts_with(&at_line(&unknown, "law")), "{err}");
        assert!(
            err.contains("`linear_resistance`") && err.contains("`orifice`"),
            "{err}"
        );

        let wrong_key =
            with_laws("[valve]\nlaw = \"orifice\"\nfill_resistance_pa_s_per_mol = 2.5e6\n");
        let err = parse(&wrong_key).unwrap_err().to_string();
        assert!(err.starts_with(&at_line(&wrong_key, "fill_res")), "{err}");
        assert!(
            err.contains("valve.fill_resistance_pa_s_per_mol (law \"orifice\")"),
            "{err}"
        );

        let missing = with_laws("[valve]\nlaw = \"orifice\"\nfill_conductance_m3_s_pa = 5e-9\n");
        let err = parse(&missing).unwrap_err().to_string();
        assert!(err.contains("valve.exhaust_conductance_m3_s_pa"), "{err}");

        let out_of_range = with_laws(
            "[bellow.effective_area]\nlaw = \"polynomial_pressure\"\n\
             coefficients_m2 = [-0.0289, 0.8362, -3.0698, 4.9616, -2.9941]\ngrowth_per_100kpa = 4.0\n",
        );
        let err = parse(&out_of_range).unwrap_err().to_string();
        assert!(err.starts_with(&at_line(&out_of_range, "growth")), "{err}");
        assert!(
            err.contains("bellow.effective_area.growth_per_100kpa"),
            "{err}"
        );
        assert!(err.contains("-0.1 to 0.1 1/(100 kPa)"), "{err}");

        let twice = with_laws(
            "[bellow]\neffective_area_poly_m2 = [-0.0289, 0.8362, -3.0698, 4.9616, -2.9941]\n\
             [bellow.effective_area]\nlaw = \"polynomial\"\n\
             coefficients_m2 = [-0.0289, 0.8362, -3.0698, 4.9616, -2.9941]\n",
        );
        let err = parse(&twice).unwrap_err().to_string();
        assert!(err.contains("give it once"), "{err}");
    }

    #[test]
    fn a_spline_area_loads_round_trips_and_names_bad_knots() {
        let spline = |body: &str| {
            with_laws(&format!(
                "[bellow.effective_area]\nlaw = \"spline\"\n{body}"
            ))
        };
        let text = spline(
            "heights_m = [0.22, 0.26, 0.3, 0.34, 0.4]\n\
             areas_m2 = [0.056, 0.0555, 0.054, 0.05, 0.045]\ngrowth_per_100kpa = 0.004\n",
        );
        let loaded = parse(&text).unwrap();
        let area = &loaded.parameters.bellow.effective_area;
        assert_eq!(area.tag(), "spline");
        assert_eq!(area.coefficients_m2(), None);
        assert_eq!(area.growth_per_100kpa(), 0.004);
        // Through its knots, and stretched by the pressure.
        assert!((area.area_m2(0.3, 0.0) - 0.054).abs() < 1e-15);
        assert!((area.area_m2(0.3, 2e5) - 0.054 * 1.008).abs() < 1e-15);
        // Its parameters are the knot areas and the growth, in order.
        assert_eq!(
            area.fields(),
            vec![
                Field::AreaKnot(0),
                Field::AreaKnot(1),
                Field::AreaKnot(2),
                Field::AreaKnot(3),
                Field::AreaKnot(4),
                Field::AreaPressureGrowth
            ]
        );
        assert_eq!(Field::AreaKnot(3).param().info.name, "s3");
        let written = truck_to_toml(&loaded.parameters);
        assert!(written.contains("law = \"spline\""), "{written}");
        assert!(
            written.contains("heights_m = [0.22, 0.26, 0.3, 0.34, 0.4]"),
            "{written}"
        );
        assert_eq!(&parse(&written).unwrap().parameters, &loaded.parameters);
        // Without a growth the area does not depend on the pressure, and none is written.
        let plain = parse(&spline(
            "heights_m = [0.22, 0.3]\nareas_m2 = [0.056, 0.054]\n",
        ))
        .unwrap()
        .parameters;
        assert!(!plain.bellow.effective_area.depends_on_pressure());
        assert!(!truck_to_toml(&plain).contains("growth_per_100kpa"));

        // Bad knots: named, with the key's line.
        for (body, key, says) in [
            (
                "heights_m = [0.22, 0.3, 0.3]\nareas_m2 = [0.056, 0.054, 0.05]\n",
                "heights_m",
                "increase strictly",
            ),
            (
                "heights_m = [0.22, 0.3]\nareas_m2 = [0.056, 0.054, 0.05]\n",
                "areas_m2",
                "2 knot positions but 3 values",
            ),
            (
                "heights_m = [0.22, 0.3]\nareas_m2 = [0.056, 5.4]\n",
                "areas_m2",
                "areas_m2[1]",
            ),
            (
                "heights_m = [0.22, 0.3]\n",
                "[bellow.effective_area]",
                "missing key `bellow.effective_area.areas_m2`",
            ),
            (
                "heights_m = [220.0, 300.0]\nareas_m2 = [0.056, 0.054]\n",
                "heights_m",
                "check the unit",
            ),
            (
                "heights_m = []\nareas_m2 = []\n",
                "heights_m",
                "1 to 16 numbers",
            ),
            (
                "heights_m = [0.22, 0.3]\nareas_m2 = [0.056, \"x\"]\n",
                "areas_m2",
                "entry 1 is not a number",
            ),
        ] {
            let text = spline(body);
            let err = parse(&text).unwrap_err().to_string();
            assert!(err.starts_with(&at_line(&text, key)), "{body}: {err}");
            assert!(err.contains(says), "{body}: {err}");
        }
    }

    #[test]
    fn model_sections_of_ours_are_checked() {
        let err = parse(&format!("{SPEC_EXAMPLE}\n[model3]\noe_load_nk = -1\n")).unwrap_err();
        assert!(err.to_string().contains("model3.oe_load_nk"), "{err}");
        let err = parse(&format!("{SPEC_EXAMPLE}\n[model3]\noe_pressure_b = []\n")).unwrap_err();
        assert!(err.to_string().contains("at least one numerator"), "{err}");
        let err = parse(&format!(
            "{SPEC_EXAMPLE}\n[slow_dynamics]\ncreep_time_constant_s = 0.0\n"
        ))
        .unwrap_err();
        assert!(err.to_string().contains("creep_time_constant_s"), "{err}");
    }
}
