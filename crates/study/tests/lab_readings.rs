//! What the study reads off the lab and the loading run before any grey-box fit, on virtual
//! trucks drawn apart from the reference (#12/#13), scored against each variant's truth:
//! - the effective area's growth with pressure `kap` from the force map, and the `truck`
//!   structure's start under it (the thesis' `F = p A(h)` averages the growth into the
//!   areas, which a model that stretches them with pressure counted twice);
//! - the gas volume's shape `A1/A0` from the loading run's settled samples (a load step
//!   compresses the gas faster than it exchanges heat, and every sample bent the shape);
//! - which held-out runs go where neither the estimation runs nor the map went.

use airsus_data::TruckParameters;
use airsus_estimate::submodel::{CrossSectionOptions, fit_cross_section};
use airsus_study::load_study;
use airsus_study::submodels::fit_submodels;
use airsus_truck::models::TRUCK_MODEL;

struct Variant {
    truth: TruckParameters,
    start_structure: TruckParameters,
    start_thesis: TruckParameters,
    cross_section_notes: Vec<String>,
    /// `A1/A0` from every sample of the loading run, as thesis 5.2.1 reads it.
    every_sample_shape: f64,
    /// The held-out runs that leave the heights the estimation runs and the map show.
    extrapolated: Vec<(String, String)>,
}

fn variant(k: u32) -> Variant {
    let dir = tempfile::tempdir().unwrap();
    let generated =
        airsus_truck::experiments::generate_variant(dir.path(), 1, k, &mut |_| {}).unwrap();
    let input = load_study(&generated.study_valve).unwrap();
    let estimation: Vec<String> = ["data-set 1", "data-set 3", "levelling 1", "road 1"]
        .map(str::to_owned)
        .to_vec();
    let (start, fits) = fit_submodels(&input, &estimation);
    let extrapolated = airsus_study::coverage::extrapolation_notes(
        &input,
        &[airsus_study::Protocol::from_roles(&input)],
        &input.truck,
    );
    let truth = airsus_data::read_truck(&dir.path().join("truth/truck_structure.toml"))
        .unwrap()
        .parameters;
    let every_sample_shape = fit_cross_section(
        &input.run("data-set 1").unwrap().run,
        &[],
        &input.truck,
        &CrossSectionOptions::new(),
    )
    .unwrap()
    .ratio_per_m;
    let cross = fits
        .fits
        .iter()
        .find(|f| f.name == "cross_section")
        .expect("a cross-section fit");
    assert!(cross.error.is_none(), "variant {k}: {cross:?}");
    Variant {
        truth,
        start_structure: start.truck_for(&TRUCK_MODEL),
        start_thesis: start.truck.clone(),
        cross_section_notes: cross.notes.clone(),
        every_sample_shape,
        extrapolated,
    }
}

fn shape(truck: &TruckParameters) -> f64 {
    let [a0, a1] = *truck.bellow.gas_volume.coefficients_m2().unwrap();
    a1 / a0
}

#[test]
fn the_lab_and_the_loading_run_read_right_on_trucks_drawn_apart() {
    for k in 0..4 {
        let v = variant(k);
        // No run leaves the heights the estimation runs and the force map show: the map
        // reaches down to 160 mm. With the map of thesis Fig 5.8 (220-400 mm), variant 2's
        // data-set 4 did (16 % of its samples, down to 195 mm), and its pressure was 6
        // points short of its ceiling.
        assert!(
            v.extrapolated.is_empty(),
            "variant {k}: {:?}",
            v.extrapolated
        );
        let area = &v.start_structure.bellow.effective_area;
        let truth_area = &v.truth.bellow.effective_area;

        // kap within 8 % (measured: 3-5 % low on every variant, 0.0038 against 0.0040 on the
        // reference), the structure's area within 0.3 % over the map's stroke at the runs'
        // pressures.
        let kap = area.growth_per_100kpa();
        let true_kap = truth_area.growth_per_100kpa();
        assert_eq!(area.tag(), "polynomial_pressure", "variant {k}");
        assert!(
            (kap / true_kap - 1.0).abs() < 0.08,
            "variant {k}: kap {kap} against {true_kap}"
        );
        for h in [0.24, 0.28, 0.32, 0.36] {
            for gauge_pa in [3e5, 4e5] {
                let relative = area.area_m2(h, gauge_pa) / truth_area.area_m2(h, gauge_pa) - 1.0;
                assert!(
                    relative.abs() < 3e-3,
                    "variant {k} at {h} m, {gauge_pa} Pa: {relative}"
                );
            }
        }
        // The thesis models keep the thesis' reading of the map (their law has no growth).
        assert_eq!(
            v.start_thesis.bellow.effective_area.tag(),
            "polynomial",
            "variant {k}"
        );

        // The volume's shape from settled samples: within 20 % of the truth on variants 0-2
        // and at most 0.6 of the error every sample makes (measured: 2, 18, 12 % against
        // 18, 37, 37 %). Variant 3's lever is 15 % stiffer than the nominal file's, which
        // moves the bellow heights the shape is read at: not asserted there.
        assert!(
            v.cross_section_notes[0].contains("120 s or more after a load change"),
            "{:?}",
            v.cross_section_notes
        );
        if k < 3 {
            let truth = shape(&v.truth);
            let settled = (shape(&v.start_thesis) / truth - 1.0).abs();
            let every = (v.every_sample_shape / truth - 1.0).abs();
            assert!(
                settled < 0.2 && settled < 0.6 * every,
                "variant {k}: A1/A0 off by {settled} from settled samples, {every} from all"
            );
        }
    }
}
