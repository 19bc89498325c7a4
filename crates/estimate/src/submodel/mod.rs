//! Submodel fits (thesis 5.2): plain functions from data to parameters, each with its
//! residual NRMSE (thesis eq 3.33) so that the fit can be judged like the thesis' tables.
//!
//! | fit | data | thesis | function |
//! |---|---|---|---|
//! | gas-volume cross-section `A(h) = A0 + A1 h` | closed-valve load-step run | eq 5.1–5.3, Table 5.1 | [`fit_cross_section`] |
//! | effective area `A_eff(h)`, 4th-degree polynomial | bellow force map | eq 3.16, 5.4, Table 5.2 | [`fit_effective_area`] |
//! | wall friction `F_c` (the `truck` structure's `fc`) | bellow force map, up and down sweeps | — | [`fit_wall_friction`] |
//! | effective area `A_eff(h)`, monotone spline through the map's heights | bellow force map | eq 3.16 | [`fit_effective_area_spline`] |
//! | valve flow resistances `R_flow1`, `R_flow2` | tank discharges | eq 3.19, 5.5, 5.6, Table 5.3 | [`fit_valve`] |
//! | valve orifice `c1`, `c2`, `bcr` (ISO 6358), the tank's gas simulated with its cooling | tank discharges | (eq 5.5 without the isothermal assumption) | [`fit_orifice`] |
//! | slow dynamics, OE `nb=1 nf=1 nk=2` | one isolated load step | 5.2.4, Tables 5.4/5.5 | [`fit_slow_dynamics`] |

mod cross_section;
pub mod derivative;
mod effective_area;
mod orifice;
mod slow_dynamics;
mod valve;
mod wall_friction;

pub use cross_section::{
    CrossSectionFit, CrossSectionOptions, CrossSectionScale, DeadVolumeFit, fit_cross_section,
    fit_dead_volume,
};
pub use effective_area::{
    AreaGrowthFit, EffectiveAreaFit, EffectiveAreaOptions, SplineAreaFit, fit_area_growth,
    fit_effective_area, fit_effective_area_spline,
};
pub use orifice::{
    LinearValveFit, OrificeDischargeFit, OrificeFit, OrificeFitOptions, fit_linear_valve,
    fit_orifice,
};
pub use slow_dynamics::{SlowDynamicsFit, SlowDynamicsOptions, fit_slow_dynamics};
pub use valve::{ChannelFit, DischargeData, DischargeFit, ValveFit, ValveFitOptions, fit_valve};
pub use wall_friction::{WallFrictionFit, fit_wall_friction, sweep_friction_n};

/// `value` against the declared range of `field`: what a fit writes into a truck must load
/// from the file it is written to.
fn check_declared(
    field: airsus_data::params::Field,
    value: f64,
) -> Result<(), crate::error::EstimateError> {
    let info = &field.param().info;
    if info.admits(value) {
        Ok(())
    } else {
        Err(crate::error::EstimateError::InvalidOption(format!(
            "the fitted `{}` = {value} lies outside its admissible range {} to {} {}; the truck is left as it was",
            info.name, info.lower, info.upper, info.unit
        )))
    }
}
