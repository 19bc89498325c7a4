//! Which samples of a held-out run lie at bellow heights that neither a protocol's estimation
//! runs nor the force map show. There every model's effective area (and whatever else depends
//! on the height) is extrapolated from elsewhere, and no estimate can be held to the run's
//! noise ceiling: the report says so beside the score instead of leaving the reader to guess.
//! (Variant 2 of the virtual truck: its data-set 4 takes the bellow 25 mm below anything the
//! estimation runs and the lab's map show; the `truck` structure's pressure NRMSE on those
//! 15 % of its samples is 75.9 % against a ceiling of 97.0.)

use airsus_data::TruckParameters;
use airsus_model::submodels::bellow_height_from_sensor_m;

use crate::input::StudyInput;
use crate::protocol::Protocol;

/// A sample counts as outside when it lies this far beyond the heights seen, m (the height
/// sensor's resolution and a margin: a few tenths of a millimetre outside is no extrapolation).
const MARGIN_M: f64 = 2e-3;

/// The smallest share of a run's samples outside the heights seen that is worth a note.
const NOTE_FRACTION: f64 = 0.01;

/// The bellow heights of a run's measured samples (eq 2.1 inverted with the lever's static
/// flex, under `truck`'s geometry), m, sample by sample; `None` for a run without measured
/// outputs.
pub(crate) fn bellow_heights_m(
    run: &airsus_data::Run,
    truck: &TruckParameters,
) -> Option<Vec<f64>> {
    let measured = run.outputs.as_ref()?;
    let g = &truck.geometry;
    let (gain, gravity) = (g.lever_gain(), truck.environment.gravity_m_s2);
    Some(
        measured
            .sensor_height_m
            .iter()
            .zip(&run.inputs.wheel_load_kg)
            .map(|(&sensor_m, &load_kg)| {
                bellow_height_from_sensor_m(
                    g.h0_m,
                    gain,
                    sensor_m,
                    g.lever_compliance_m_per_n,
                    load_kg,
                    gravity,
                )
            })
            .collect(),
    )
}

/// [`bellow_heights_m`]' finite values (none for a run without measured outputs).
fn finite_bellow_heights_m(run: &airsus_data::Run, truck: &TruckParameters) -> Vec<f64> {
    bellow_heights_m(run, truck)
        .unwrap_or_default()
        .into_iter()
        .filter(|h| h.is_finite())
        .collect()
}

fn range(heights: impl IntoIterator<Item = f64>) -> Option<(f64, f64)> {
    heights.into_iter().fold(None, |acc, h| match acc {
        None => Some((h, h)),
        Some((lo, hi)) => Some((lo.min(h), hi.max(h))),
    })
}

/// Per held-out run of each protocol whose samples leave the bellow heights the protocol's
/// estimation runs and the force map cover (their hull, widened by 2 mm) in 1 % of its
/// samples or more: the run's name and a note saying how many, how far and why it matters.
pub fn extrapolation_notes(
    input: &StudyInput,
    protocols: &[Protocol],
    truck: &TruckParameters,
) -> Vec<(String, String)> {
    let map_range = input
        .force_map
        .as_ref()
        .and_then(|map| range(map.bellow_height_m.iter().copied()));
    let mut notes = Vec::new();
    for protocol in protocols {
        let seen = range(
            input
                .runs
                .iter()
                .filter(|r| protocol.estimation.contains(&r.name))
                .flat_map(|r| finite_bellow_heights_m(&r.run, truck))
                .chain(map_range.into_iter().flat_map(|(lo, hi)| [lo, hi])),
        );
        let Some((low, high)) = seen else { continue };
        for run in input
            .runs
            .iter()
            .filter(|r| !protocol.estimation.contains(&r.name))
        {
            let heights = finite_bellow_heights_m(&run.run, truck);
            let below = heights.iter().filter(|&&h| h < low - MARGIN_M).count();
            let above = heights.iter().filter(|&&h| h > high + MARGIN_M).count();
            let outside = below + above;
            if heights.is_empty() || (outside as f64) < NOTE_FRACTION * heights.len() as f64 {
                continue;
            }
            let Some((run_low, run_high)) = range(heights.iter().copied()) else {
                continue;
            };
            notes.push((
                run.name.clone(),
                format!(
                    "protocol `{}`: {:.0} % of its samples lie at bellow heights its estimation runs and the force map do not show ({:.0}-{:.0} mm; this run {:.0}-{:.0} mm): there every model's area law is extrapolated, and a score below the ceiling may be the data's limit, not the model's",
                    protocol.name,
                    100.0 * outside as f64 / heights.len() as f64,
                    low * 1e3,
                    high * 1e3,
                    run_low * 1e3,
                    run_high * 1e3,
                ),
            ));
        }
    }
    notes
}
