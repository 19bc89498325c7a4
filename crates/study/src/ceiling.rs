//! The noise floor of each run: the NRMSE no model can beat, to report every fit beside it.

use airsus_data::units::{PA_PER_KPA, mm_from_m};
use airsus_report::results::{LoggedInputCeiling, NoiseCeiling};
use airsus_validate::{estimate_noise_std, noise_ceiling_percent, nrmse_percent, rmse};

use crate::input::StudyRunData;

/// The run's ceiling: from its truth file when the study names one (the noise-free outputs
/// against the measurements), otherwise estimated from the measurements' own noise
/// ([`estimate_noise_std`]). With the noise-free run as its log tells it
/// ([`StudyRunData::truth_logged_input`]), also the ceiling of a model driven by the logged
/// load. `None` for a run without measured outputs or a constant output.
pub fn noise_ceiling(run: &StudyRunData) -> Option<NoiseCeiling> {
    let measured = run.run.outputs.as_ref()?;
    let (h, p) = (&measured.sensor_height_m, &measured.bellow_gauge_pa);
    let (source, height_percent, pressure_percent, height_std, pressure_std) = match &run.truth {
        Some(truth) => (
            "truth",
            nrmse_percent(h, &truth.sensor_height_m).ok()?,
            nrmse_percent(p, &truth.bellow_gauge_pa).ok()?,
            rmse(h, &truth.sensor_height_m).ok()?,
            rmse(p, &truth.bellow_gauge_pa).ok()?,
        ),
        None => {
            let (height_std, pressure_std) = (estimate_noise_std(h)?, estimate_noise_std(p)?);
            (
                "estimated",
                noise_ceiling_percent(h, height_std).ok()?,
                noise_ceiling_percent(p, pressure_std).ok()?,
                height_std,
                pressure_std,
            )
        }
    };
    let logged_input = run.truth_logged_input.as_ref().and_then(|truth| {
        Some(LoggedInputCeiling {
            height_percent: nrmse_percent(h, &truth.sensor_height_m).ok()?,
            pressure_percent: nrmse_percent(p, &truth.bellow_gauge_pa).ok()?,
        })
    });
    Some(NoiseCeiling {
        source: source.to_owned(),
        height_percent,
        pressure_percent,
        height_noise_std_mm: mm_from_m(height_std),
        pressure_noise_std_kpa: pressure_std / PA_PER_KPA,
        logged_input,
    })
}
