//! The seconds after a logged load change, left out of the grey-box loss. A log records a
//! step where the wheel takes the load over seconds (3-8 s on the virtual truck, each time
//! differently); fitted to those seconds, the `truck` structure started at its true values
//! on a loading run and a valve run runs away to a fast creep that mimics the transitions,
//! and the valve run it also explains collapses. Left out, the fit stays near the truth.

use airsus_estimate::{
    GreyboxOptions, GreyboxProblem, LoadRamp, MultiStart, NoProgress, PrefixOptions, StartMethod,
    estimate_with_starts,
};
use airsus_study::load_study;
use airsus_truck::models::{build_any_model, model_entry};

#[test]
fn leaving_out_the_load_transitions_keeps_a_fit_at_the_truth_near_it() {
    let dir = tempfile::tempdir().unwrap();
    let generated = airsus_truck::experiments::generate(dir.path(), 1, &mut |_| {}).unwrap();
    let input = load_study(&generated.study_valve).unwrap();
    let truth = airsus_data::read_truck(&dir.path().join("truth/truck_structure.toml")).unwrap();
    let model = build_any_model("truck", &truth.parameters).unwrap();
    let runs: Vec<&airsus_data::Run> = ["data-set 3", "data-set 1"]
        .iter()
        .map(|n| &input.run(n).unwrap().run)
        .collect();
    let free = model_entry("truck").unwrap().free_parameters(
        airsus_model::Excitation {
            valve: true,
            road: false,
        },
        &*model,
    );
    // Data-set 3's pressure NRMSE (%) after the fit, and the fitted creep time constant.
    let fit = |exclude_s: f64| {
        let problem =
            GreyboxProblem::new(&*model, &runs, &free).with_exclusion_after_load_changes(exclude_s);
        let (joint, _) = estimate_with_starts(
            &problem,
            &GreyboxOptions::default(),
            &MultiStart::default(),
            StartMethod::Prefix,
            &PrefixOptions::default(),
            // The steps as logged: what the exclusion is for.
            LoadRamp::Logged,
            &mut NoProgress,
        )
        .unwrap();
        let est = joint.estimate;
        let ds3 = est.fits.iter().find(|f| f.run == "data-set 3").unwrap();
        (
            ds3.pressure_estimated_percent.unwrap(),
            est.parameter("tc").unwrap().estimate,
        )
    };
    // Measured: 7.9 % and tc 0.86 s with every sample; 88.0 % and tc 33 s (true 25 s) with
    // 10 s left out; the truth itself scores 90.8 %.
    let (all_p, all_tc) = fit(0.0);
    let (excluded_p, excluded_tc) = fit(10.0);
    assert!(
        excluded_p > 80.0 && excluded_tc > 10.0,
        "10 s left out: data-set 3 pressure {excluded_p:.1} %, tc {excluded_tc:.2} s"
    );
    assert!(
        all_p < excluded_p - 30.0,
        "every sample: {all_p:.1} % (tc {all_tc:.2} s), 10 s left out: {excluded_p:.1} %"
    );
}
