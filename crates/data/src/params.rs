//! The physical parameters of a truck file, declared once (SPEC §5 `--free` names).
//!
//! Each [`Param`] names a value by its short name, says where it lives in the truck file
//! (section, key, index) and in [`TruckParameters`], and gives its unit, description and
//! admissible range. The truck-file reader checks values against these ranges, the models'
//! parameter catalogues and the estimator's default bounds are these ranges, and `airsus
//! models` prints them: one declaration, no copies.
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
//! | `kap` | `bellow.effective_area.growth_per_100kpa` (law `polynomial_pressure`) | 1/(100 kPa) |
//! | `c1`, `c2`, `bcr` | `valve.fill/exhaust_conductance_m3_s_pa`, `valve.critical_pressure_ratio` (law `orifice`) | m³/(s Pa), 1 |
//! | `kc`, `tc`, `fc`, `kdahl`, `tth`, `rline` (truck) | `effects.*` | N/m, s, N, N/m, s, Pa s/mol |
//!
//! A law's parameters exist only while the truck file names that law (see
//! [`crate::laws`]): a model's parameter set is built from the laws of its truck
//! ([`law_fields`]).
//!
//! The bounds are the physically admissible ranges; they are deliberately wide — they exclude
//! nonsense (negative masses, stiffness off by 1000, a unit slip), not unlikely values.

use crate::laws::LawFamily;
use crate::truck::TruckParameters;

/// Description of one freeable parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterInfo {
    /// Short name used by `--free` (SPEC §5: `p0`..`p4`, `a0`, `a1`, `m2`, `ig`, `kf`, `kw`,
    /// `kscl`, `rflow1`, `rflow2`, `ksd`; models with more document their own).
    pub name: &'static str,
    pub unit: &'static str,
    pub description: &'static str,
    /// Physically admissible range; the estimator's default bounds.
    pub lower: f64,
    pub upper: f64,
    /// Where the value lives in a truck file; `None` for a parameter without a truck-file
    /// key (the `truck` structure's effects, test models).
    pub field: Option<Field>,
    /// What data determine it, for the message when a run set does not (empty: not said).
    pub needs: &'static str,
    /// The magnitude its values usually have, in its unit, for a parameter whose file value
    /// may be 0 (an effect the thesis leaves out): the floor of the estimator's scale and of
    /// its multi-start spread. `None`: the nominal value's magnitude, or a thousandth of the
    /// range where that is 0.
    pub typical: Option<f64>,
}

impl ParameterInfo {
    pub const fn new(
        name: &'static str,
        unit: &'static str,
        description: &'static str,
        (lower, upper): (f64, f64),
        field: Option<Field>,
    ) -> Self {
        Self {
            name,
            unit,
            description,
            lower,
            upper,
            field,
            needs: "",
            typical: None,
        }
    }

    /// The same, saying what data determine it.
    pub const fn needing(mut self, needs: &'static str) -> Self {
        self.needs = needs;
        self
    }

    /// The same, with the magnitude its values usually have ([`Self::typical`]).
    pub const fn typically(mut self, magnitude: f64) -> Self {
        self.typical = Some(magnitude);
        self
    }

    /// Whether `value` is inside the admissible range (NaN is not).
    pub fn admits(&self, value: f64) -> bool {
        value >= self.lower && value <= self.upper
    }
}

/// Where a named parameter lives in [`TruckParameters`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    EffectiveArea(usize),
    CrossSection(usize),
    /// `vd`: the dead volume of the area-integral volume law.
    DeadVolume,
    Unsprung,
    LeverInertia,
    HingeFriction,
    TireStiffness,
    /// `cw`: the tire's damping.
    TireDamping,
    /// `dscl`: the damper table's scale.
    DamperScale,
    /// `dc0, dc1, ..`: per-point factors on the damper table's forces (at most
    /// [`MAX_DAMPER_CORRECTIONS`]), present while the truck file names `damper.correction`.
    DamperCorrection(usize),
    LeverCompliance,
    FillResistance,
    ExhaustResistance,
    SlowForceScale,
    CreepStiffness,
    CreepTimeConstant,
    /// `κ` of the pressure-dependent effective area.
    AreaPressureGrowth,
    /// `s0, s1, ..`: a spline effective area's knot areas (at most [`MAX_AREA_KNOTS`]).
    AreaKnot(usize),
    /// The orifice valve law's sonic conductances and critical ratio.
    FillConductance,
    ExhaustConductance,
    CriticalPressureRatio,
    /// The `truck` structure's wall, gas and supply-line effects (`[effects]`).
    WallCreepStiffness,
    WallCreepTime,
    WallFrictionForce,
    WallFrictionStiffness,
    GasThermalTime,
    LineResistance,
}

impl Field {
    /// Where the value sits in a truck file: section, key and, for an array, the index.
    pub fn location(self) -> (&'static str, &'static str, Option<usize>) {
        match self {
            Self::EffectiveArea(i) => ("bellow", "effective_area_poly_m2", Some(i)),
            Self::CrossSection(i) => ("bellow", "cross_section_m2", Some(i)),
            Self::DeadVolume => ("bellow.gas_volume", "dead_volume_m3", None),
            Self::Unsprung => ("mass", "unsprung_kg", None),
            Self::LeverInertia => ("mass", "lever_inertia_kg_m2", None),
            Self::HingeFriction => ("bellow", "hinge_friction_n_s_per_m", None),
            Self::TireStiffness => ("tire", "stiffness_n_per_m", None),
            Self::TireDamping => ("tire", "damping_n_s_per_m", None),
            Self::DamperScale => ("damper", "scale", None),
            Self::DamperCorrection(i) => ("damper", "correction", Some(i)),
            Self::LeverCompliance => ("geometry", "lever_compliance_m_per_n", None),
            Self::FillResistance => ("valve", "fill_resistance_pa_s_per_mol", None),
            Self::ExhaustResistance => ("valve", "exhaust_resistance_pa_s_per_mol", None),
            Self::SlowForceScale => ("slow_dynamics", "force_scale_n_per_m", None),
            Self::CreepStiffness => ("slow_dynamics", "creep_stiffness_n_per_m", None),
            Self::CreepTimeConstant => ("slow_dynamics", "creep_time_constant_s", None),
            Self::AreaPressureGrowth => ("bellow.effective_area", "growth_per_100kpa", None),
            Self::AreaKnot(i) => ("bellow.effective_area", "areas_m2", Some(i)),
            Self::FillConductance => ("valve", "fill_conductance_m3_s_pa", None),
            Self::ExhaustConductance => ("valve", "exhaust_conductance_m3_s_pa", None),
            Self::CriticalPressureRatio => ("valve", "critical_pressure_ratio", None),
            Self::WallCreepStiffness => ("effects", "creep_stiffness_n_per_m", None),
            Self::WallCreepTime => ("effects", "creep_time_constant_s", None),
            Self::WallFrictionForce => ("effects", "friction_force_n", None),
            Self::WallFrictionStiffness => ("effects", "friction_stiffness_n_per_m", None),
            Self::GasThermalTime => ("effects", "thermal_time_constant_s", None),
            Self::LineResistance => ("effects", "line_resistance_pa_s_per_mol", None),
        }
    }

    /// The law family whose law carries this value, if any.
    pub fn law_family(self) -> Option<LawFamily> {
        match self {
            Self::EffectiveArea(_) | Self::AreaKnot(_) | Self::AreaPressureGrowth => {
                Some(LawFamily::EffectiveArea)
            }
            Self::CrossSection(_) | Self::DeadVolume => Some(LawFamily::GasVolume),
            Self::FillResistance
            | Self::ExhaustResistance
            | Self::FillConductance
            | Self::ExhaustConductance
            | Self::CriticalPressureRatio => Some(LawFamily::ValveFlow),
            _ => None,
        }
    }

    /// The declaration of this value.
    pub fn param(self) -> &'static Param {
        CATALOG
            .iter()
            .find(|p| p.field == self)
            .expect("every field is declared in CATALOG (tested)")
    }
}

/// The most points of a damper table that carry their own correction factor (`dc0`..`dc11`):
/// a data sheet's table has 6-10 (the virtual truck's 7), each of which is declared in
/// [`CATALOG`].
pub const MAX_DAMPER_CORRECTIONS: usize = 12;

/// The most knots a spline effective area has (`s0`..`s15`): a force map's heights (thesis
/// Fig 5.8 has 11, the virtual truck's lab 10), each of which is declared in [`CATALOG`].
pub const MAX_AREA_KNOTS: usize = 16;

/// The SPEC parameters of every model on Model 2's lever (QCM 2 and the models built on it),
/// with the thesis' laws; [`law_fields`] puts the truck's own laws' parameters in their place.
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
    // Last, so that Model 1's and Model 2's parameters keep their places (an FMU's value
    // references; the models built on them shift theirs by one, and an FMU's configuration
    // names parameters, not references).
    Field::DamperScale,
    // After the damper's scale, for the same reason.
    Field::TireDamping,
];

/// One named parameter: its description and its home in the truck parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    pub info: ParameterInfo,
    pub field: Field,
}

impl Param {
    /// The same, saying what data determine it.
    pub const fn needing(mut self, needs: &'static str) -> Self {
        self.info.needs = needs;
        self
    }

    /// The same, with the magnitude its values usually have ([`ParameterInfo::typical`]).
    pub const fn typically(mut self, magnitude: f64) -> Self {
        self.info.typical = Some(magnitude);
        self
    }
}

/// One declaration: the field (truck-file home) once, the description beside it.
const fn param(
    field: Field,
    name: &'static str,
    unit: &'static str,
    description: &'static str,
    lower: f64,
    upper: f64,
) -> Param {
    Param {
        info: ParameterInfo::new(name, unit, description, (lower, upper), Some(field)),
        field,
    }
}

/// One knot area of the spline effective-area law.
const fn knot(i: usize, name: &'static str) -> Param {
    param(
        Field::AreaKnot(i),
        name,
        "m²",
        "effective area at a knot height of the spline law (monotone cubic between knots)",
        1e-4,
        1.0,
    )
    .needing("the bellow force map at the knot's height, or loads that hold the bellow there")
}

/// One point's correction factor of the damper table.
const fn damper_point(i: usize, name: &'static str) -> Param {
    param(
        Field::DamperCorrection(i),
        name,
        "-",
        "damper table correction: this point's force times it, on top of dscl (the table's shape)",
        0.2,
        5.0,
    )
    .needing("road input that strokes the damper at this point's velocity and its neighbours'")
}

/// All SPEC §5 names plus the creep element's (`m2xh`). `ksd` appears twice with different
/// meanings; a model picks one.
pub const CATALOG: &[Param] = &[
    param(
        Field::EffectiveArea(0),
        "p0",
        "m²",
        "effective area A_eff = p0 + p1 h + .. + p4 h⁴, constant term (eq 5.4)",
        -1.0,
        1.0,
    )
    .needing("loads over a range of heights (loading runs), or the bellow force map"),
    param(
        Field::EffectiveArea(1),
        "p1",
        "m",
        "effective area, linear coefficient (eq 5.4; thesis Table 5.2 misprints 0.08362 for 0.8362)",
        -10.0,
        10.0,
    )
    .needing("loads over a range of heights (loading runs), or the bellow force map"),
    param(
        Field::EffectiveArea(2),
        "p2",
        "1",
        "effective area, quadratic coefficient (eq 5.4)",
        -100.0,
        100.0,
    )
    .needing("loads over a range of heights (loading runs), or the bellow force map"),
    param(
        Field::EffectiveArea(3),
        "p3",
        "1/m",
        "effective area, cubic coefficient (eq 5.4)",
        -100.0,
        100.0,
    )
    .needing("loads over a range of heights (loading runs), or the bellow force map"),
    param(
        Field::EffectiveArea(4),
        "p4",
        "1/m²",
        "effective area, quartic coefficient (eq 5.4)",
        -100.0,
        100.0,
    )
    .needing("loads over a range of heights (loading runs), or the bellow force map"),
    param(
        Field::CrossSection(0),
        "a0",
        "m²",
        "gas-volume cross-section A = a0 + a1 h, constant term (eq 5.1)",
        1e-3,
        5.0,
    )
    .needing("valve action: the gas volume's scale shows only when air flows in or out"),
    param(
        Field::CrossSection(1),
        "a1",
        "m",
        "gas-volume cross-section, slope (eq 5.1)",
        -5.0,
        5.0,
    )
    .needing("valve action at different heights"),
    param(
        Field::DeadVolume,
        "vd",
        "m³",
        "dead volume of the area-integral volume law V = vd + the integral of A_eff",
        0.0,
        1.0,
    )
    .needing("valve action: the gas volume's scale shows only when air flows in or out"),
    param(
        Field::Unsprung,
        "m2",
        "kg",
        "unsprung mass m2 (axle, wheel; thesis 3.1)",
        10.0,
        3000.0,
    )
    .needing("fast changes: load steps or road input (the wheel's own dynamics)"),
    param(
        Field::LeverInertia,
        "ig",
        "kg m²",
        "lever + axle inertia about the hinge I_g (eq 3.8; nominal m2 l1²)",
        1.0,
        1e4,
    )
    .needing("fast changes: load steps or road input (the lever's rotation)"),
    param(
        Field::HingeFriction,
        "kf",
        "N s/m",
        "hinge friction k_f, viscous (eq 3.4)",
        0.0,
        1e6,
    )
    .needing("fast motion: load steps or road input")
    // A lever's rubber bushings damp by a few hundred to a few thousand N s/m, a tenth of
    // the damper's slope or less; the thesis starts from 0.1, which as a scale would make
    // the finite-difference step move nothing.
    .typically(1000.0),
    param(
        Field::TireStiffness,
        "kw",
        "N/m",
        "tire stiffness k_w (eq 3.15)",
        1e5,
        1e8,
    )
    .needing("road input (the tire compresses)"),
    param(
        Field::TireDamping,
        "cw",
        "N s/m",
        "tire damping c_w beside eq 3.15's spring (0: the thesis' tire)",
        0.0,
        1e5,
    )
    .needing("road input (the tire compresses fast)")
    // A truck tire damps its wheel hop by a few kN s/m; the thesis' tire by none.
    .typically(3000.0),
    param(
        Field::DamperScale,
        "dscl",
        "-",
        "damper table scale: every force of the table times it (thesis 3.1.2)",
        0.1,
        10.0,
    )
    .needing("road input or fast motion (the damper strokes)"),
    damper_point(0, "dc0"),
    damper_point(1, "dc1"),
    damper_point(2, "dc2"),
    damper_point(3, "dc3"),
    damper_point(4, "dc4"),
    damper_point(5, "dc5"),
    damper_point(6, "dc6"),
    damper_point(7, "dc7"),
    damper_point(8, "dc8"),
    damper_point(9, "dc9"),
    damper_point(10, "dc10"),
    damper_point(11, "dc11"),
    param(
        Field::LeverCompliance,
        "kscl",
        "m/N",
        "static lever flex per newton of wheel load k_scl (eq 3.14)",
        0.0,
        1e-5,
    )
    .needing("load steps (the lever's flex is the instant height jump)"),
    param(
        Field::FillResistance,
        "rflow1",
        "Pa s/mol",
        "fill-channel flow resistance R_flow1 (eq 3.19)",
        1e3,
        1e11,
    )
    .needing("fill pulses (valve 1)"),
    param(
        Field::ExhaustResistance,
        "rflow2",
        "Pa s/mol",
        "exhaust-channel flow resistance R_flow2 (eq 3.19)",
        1e3,
        1e11,
    )
    .needing("exhaust pulses (valve 2)"),
    param(
        Field::SlowForceScale,
        "ksd",
        "N/m",
        "slow-force scale k_sd: extra bellow force per metre of OE output (eq 4.4)",
        0.0,
        1e8,
    )
    .needing("long standstills after load changes (the slow settling)"),
    param(
        Field::CreepStiffness,
        "ksd",
        "N/m",
        "creep stiffness k_sd of the bellow-wall Maxwell element (m2xh)",
        0.0,
        1e8,
    )
    .needing("long standstills after load changes (the slow settling)"),
    param(
        Field::CreepTimeConstant,
        "tsd",
        "s",
        "creep relaxation time constant τ_sd of the Maxwell element (m2xh)",
        0.1,
        1e5,
    )
    .needing("long standstills after load changes (the slow settling)"),
    param(
        Field::AreaPressureGrowth,
        "kap",
        "1/(100 kPa)",
        "growth of the effective area with pressure (wall stretch), law polynomial_pressure",
        -0.1,
        0.1,
    )
    .needing("loads over a range of pressures"),
    knot(0, "s0"),
    knot(1, "s1"),
    knot(2, "s2"),
    knot(3, "s3"),
    knot(4, "s4"),
    knot(5, "s5"),
    knot(6, "s6"),
    knot(7, "s7"),
    knot(8, "s8"),
    knot(9, "s9"),
    knot(10, "s10"),
    knot(11, "s11"),
    knot(12, "s12"),
    knot(13, "s13"),
    knot(14, "s14"),
    knot(15, "s15"),
    param(
        Field::FillConductance,
        "c1",
        "m3/(s Pa)",
        "ISO 6358 sonic conductance of the fill channel, law orifice",
        1e-11,
        1e-6,
    )
    .needing("fill pulses at several supply pressures"),
    param(
        Field::ExhaustConductance,
        "c2",
        "m3/(s Pa)",
        "ISO 6358 sonic conductance of the exhaust channel, law orifice",
        1e-11,
        1e-6,
    )
    .needing("exhaust pulses at several bellow pressures"),
    param(
        Field::CriticalPressureRatio,
        "bcr",
        "1",
        "ISO 6358 critical pressure ratio of both channels, law orifice",
        0.0,
        0.9,
    )
    .needing("fill and exhaust pulses over a range of pressure ratios"),
    param(
        Field::WallCreepStiffness,
        "kc",
        "N/m",
        "creep stiffness of the bellow wall (Maxwell element, truck)",
        0.0,
        1e6,
    )
    .needing("long standstills after load changes (the creep)"),
    param(
        Field::WallCreepTime,
        "tc",
        "s",
        "creep relaxation time (truck)",
        0.1,
        1e4,
    )
    .needing("long standstills after load changes (the creep)"),
    param(
        Field::WallFrictionForce,
        "fc",
        "N",
        "bellow wall sliding friction (Dahl, truck)",
        0.0,
        1e4,
    )
    .needing("load reversals: a fill then an exhaust, or a load on then off (the hysteresis)"),
    param(
        Field::WallFrictionStiffness,
        "kdahl",
        "N/m",
        "pre-sliding stiffness of the wall friction (Dahl, truck)",
        1e3,
        1e8,
    )
    .needing("small reversals (the pre-sliding hysteresis)"),
    param(
        Field::GasThermalTime,
        "tth",
        "s",
        "thermal time constant of the bellow gas (truck)",
        0.1,
        1e4,
    )
    .needing("valve pulses (the gas heats while filling and cools after)"),
    param(
        Field::LineResistance,
        "rline",
        "Pa s/mol",
        "supply line resistance between tank and valve (every model, when the file names it)",
        1e3,
        1e9,
    )
    .needing("long fill pulses (the supply line drains)"),
];

/// The fields of `fields` with every law's parameters replaced by those of `truck`'s law of
/// that family, in place of the first field of the family (the rest of the family dropped).
/// With the thesis' laws this is `fields` unchanged when `fields` lists each family whole and
/// in the law's order (as `LEVER_MODEL_FIELDS` does); a family listed in part becomes the
/// whole law. The damper's scale is followed by the table's per-point corrections while
/// `truck` names them (`damper.correction`): not a law that others replace, but parameters
/// that exist by the file as a law's do. So is the supply line's resistance (`rline`) after
/// the valve's law, while `truck` names it (`effects.line_resistance_pa_s_per_mol`).
pub fn law_fields(fields: &[Field], truck: &TruckParameters) -> Vec<Field> {
    let mut out = Vec::with_capacity(fields.len() + 2);
    let mut done: Vec<LawFamily> = Vec::new();
    for &field in fields {
        match field.law_family() {
            // The table's per-point corrections follow its scale, while the file names them.
            None if field == Field::DamperScale => {
                out.push(field);
                out.extend((0..truck.damper.correction.len()).map(Field::DamperCorrection));
            }
            None => out.push(field),
            Some(family) if !done.contains(&family) => {
                done.push(family);
                out.extend(match family {
                    LawFamily::EffectiveArea => truck.bellow.effective_area.fields(),
                    LawFamily::GasVolume => truck.bellow.gas_volume.fields(),
                    LawFamily::ValveFlow => truck.valve.fields(),
                });
                // A supply line the file names is part of the valve's law in every model
                // (`airsus_model`'s corner); the `truck` structure lists it itself.
                if family == LawFamily::ValveFlow
                    && truck.effects.line_resistance_pa_s_per_mol.is_some()
                    && !fields.contains(&Field::LineResistance)
                {
                    out.push(Field::LineResistance);
                }
            }
            Some(_) => {}
        }
    }
    out
}

/// The names that play the same part as `name` under the other laws of its family (a valve
/// channel's flow coefficient: `rflow1` and `c1`, `rflow2` and `c2`), `name` first; just
/// `name` when it has none. A default free set written with the thesis' names thereby fits
/// a model under any law.
pub fn same_part_names(name: &'static str) -> Vec<&'static str> {
    let Some(param) = CATALOG.iter().find(|p| p.info.name == name) else {
        return vec![name];
    };
    let mut names = vec![name];
    for channel in crate::laws::VALVE_CHANNELS
        .iter()
        .chain(&crate::laws::VOLUME_SCALES)
    {
        if channel.contains(&param.field) {
            names.extend(
                channel
                    .iter()
                    .map(|f| f.param().info.name)
                    .filter(|n| *n != name),
            );
        }
    }
    names
}

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

/// The value of `field` in `truck`; NaN when `truck` has no such value (a law's parameter
/// under another law, an optional value not given).
pub fn get(truck: &TruckParameters, field: Field) -> f64 {
    let e = &truck.effects;
    let value = match field.law_family() {
        Some(LawFamily::EffectiveArea) => {
            return truck.bellow.effective_area.get(field).unwrap_or(f64::NAN);
        }
        Some(LawFamily::GasVolume) => {
            return truck.bellow.gas_volume.get(field).unwrap_or(f64::NAN);
        }
        Some(LawFamily::ValveFlow) => return truck.valve.get(field).unwrap_or(f64::NAN),
        None => match field {
            Field::Unsprung => Some(truck.mass.unsprung_kg),
            Field::LeverInertia => Some(truck.mass.lever_inertia_kg_m2),
            Field::HingeFriction => Some(truck.bellow.hinge_friction_n_s_per_m),
            Field::TireStiffness => Some(truck.tire.stiffness_n_per_m),
            Field::TireDamping => Some(truck.tire.damping_n_s_per_m),
            Field::DamperScale => Some(truck.damper.scale),
            Field::DamperCorrection(i) => truck.damper.correction.get(i).copied(),
            Field::LeverCompliance => Some(truck.geometry.lever_compliance_m_per_n),
            Field::SlowForceScale => truck.slow_dynamics.force_scale,
            Field::CreepStiffness => truck.slow_dynamics.creep_stiffness_n_per_m,
            Field::CreepTimeConstant => truck.slow_dynamics.creep_time_constant_s,
            Field::WallCreepStiffness => e.creep_stiffness_n_per_m,
            Field::WallCreepTime => e.creep_time_constant_s,
            Field::WallFrictionForce => e.friction_force_n,
            Field::WallFrictionStiffness => e.friction_stiffness_n_per_m,
            Field::GasThermalTime => e.thermal_time_constant_s,
            Field::LineResistance => e.line_resistance_pa_s_per_mol,
            _ => None,
        },
    };
    value.unwrap_or(f64::NAN)
}

/// Stores `value` as `field` of `truck`; `false` when `truck`'s laws have no such parameter
/// (nothing is changed then).
pub fn set(truck: &mut TruckParameters, field: Field, value: f64) -> bool {
    let slot = match field.law_family() {
        Some(LawFamily::EffectiveArea) => return truck.bellow.effective_area.set(field, value),
        Some(LawFamily::GasVolume) => return truck.bellow.gas_volume.set(field, value),
        Some(LawFamily::ValveFlow) => return truck.valve.set(field, value),
        None => match field {
            Field::Unsprung => &mut truck.mass.unsprung_kg,
            Field::LeverInertia => &mut truck.mass.lever_inertia_kg_m2,
            Field::HingeFriction => &mut truck.bellow.hinge_friction_n_s_per_m,
            Field::TireStiffness => &mut truck.tire.stiffness_n_per_m,
            Field::TireDamping => &mut truck.tire.damping_n_s_per_m,
            Field::DamperScale => &mut truck.damper.scale,
            Field::DamperCorrection(i) => {
                // A table without corrections has them all at 1: naming one names them all.
                let points = truck.damper.velocity_m_s.len();
                if i >= points.min(MAX_DAMPER_CORRECTIONS) {
                    return false;
                }
                truck.damper.correction.resize(points, 1.0);
                truck.damper.correction[i] = value;
                return true;
            }
            Field::LeverCompliance => &mut truck.geometry.lever_compliance_m_per_n,
            Field::SlowForceScale => {
                truck.slow_dynamics.force_scale = Some(value);
                return true;
            }
            Field::CreepStiffness => {
                truck.slow_dynamics.creep_stiffness_n_per_m = Some(value);
                return true;
            }
            Field::CreepTimeConstant => {
                truck.slow_dynamics.creep_time_constant_s = Some(value);
                return true;
            }
            other => match truck.effects.slot(other) {
                Some(slot) => {
                    *slot = Some(value);
                    return true;
                }
                None => return false,
            },
        },
    };
    *slot = value;
    true
}
