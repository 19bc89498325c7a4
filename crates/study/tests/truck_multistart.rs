//! Issue #12, item 6: starting 50 % off in every freed parameter reaches the optimum a start
//! at the truth reaches, for the `truck` structure on the virtual truck's logged runs (the
//! estimate crate's own test does it for Model 2 on Model 2's data).

use airsus_data::read_run;
use airsus_estimate::{
    GreyboxOptions, GreyboxProblem, MultiStart, NoProgress, estimate, estimate_multistart,
};
use airsus_truck::models::build_any_model;

#[test]
fn the_truck_structure_from_fifty_percent_off_reaches_the_optimum_of_a_start_at_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    airsus_truck::experiments::generate(dir.path(), 1, &mut |_| {}).unwrap();
    let truth = airsus_data::read_truck(&dir.path().join("truth/truck_structure.toml"))
        .unwrap()
        .parameters;
    // The logged outputs under the load the wheel took (the truth's ramps, not the log's
    // steps): what is left between the structure and the data is the sensors' noise, so
    // the optimum is the optimiser's to find.
    let logged_under_true_load = |name: &str| {
        let mut run = read_run(&dir.path().join(format!("{name}.csv"))).unwrap();
        let truth = read_run(&dir.path().join(format!("truth/{name}.csv"))).unwrap();
        run.inputs.wheel_load_kg = truth.inputs.wheel_load_kg;
        run
    };
    let (ds1, ds3) = (logged_under_true_load("ds1"), logged_under_true_load("ds3"));
    let runs = [&ds1, &ds3];
    let free = ["kc", "tc", "fc", "tth", "rline"];
    let options = GreyboxOptions::default();
    let at_truth_model = build_any_model("truck", &truth).unwrap();
    let at_truth = GreyboxProblem::new(&*at_truth_model, &runs, &free);
    let reference = estimate(&at_truth, &options, &mut NoProgress).unwrap();
    let mut start = build_any_model("truck", &truth).unwrap();
    for (name, factor) in free.iter().zip([1.5, 0.5, 1.5, 0.5, 1.5]) {
        let v = start.parameter(name).unwrap();
        start.set_parameter(name, v * factor).unwrap();
    }
    let off = GreyboxProblem::new(&*start, &runs, &free);
    let ms = MultiStart {
        count: 4,
        spread: 0.5,
        seed: 3,
        screen: 0,
    };
    let (best, summary) = estimate_multistart(&off, &options, &ms, &mut NoProgress).unwrap();
    println!(
        "loss from the truth {:.6e}, multi-start from 50 % off {:.6e}, every start {:?}",
        reference.loss_estimated, best.loss_estimated, summary.losses
    );
    assert_eq!(summary.failed, 0);
    // Measured: every start ends within 0.01 % of the best loss, which is 0.25 % below
    // where the fit started at the truth stops (the creep's stiffness and time trade along
    // a flat valley: 18.4 kN/m and 21.4 s against 20.0 kN/m and 20.4 s).
    assert!(
        best.loss_estimated <= reference.loss_estimated * (1.0 + 1e-3),
        "{} vs {}",
        best.loss_estimated,
        reference.loss_estimated
    );
    assert!(
        summary
            .losses
            .iter()
            .all(|l| *l <= best.loss_estimated * (1.0 + 1e-3)),
        "{:?}",
        summary.losses
    );
    // The same optimum as from the truth, and near the truth: measured kc 18.4 / 20.0 / 18
    // kN/m (multi-start / from the truth / truth), tc 21.4 / 20.4 / 25 s, fc 131 / 132 /
    // 120 N, tth 20.1 / 19.2 / 20 s. The line's resistance comes out 25 % low from both
    // starts (302 / 304 against 400 kPa s/mol): a bias of these data, not of the optimiser
    // (not looked into further). The local fit alone from 50 % off reaches the same loss
    // here (measured 1.446779e-3): on these five parameters the landscape has one valley.
    for (name, to_reference, to_truth) in [
        ("kc", 0.10, 0.10),
        ("tc", 0.10, 0.20),
        ("fc", 0.02, 0.15),
        ("tth", 0.05, 0.05),
        ("rline", 0.02, 0.30),
    ] {
        let got = best.parameter(name).unwrap().estimate;
        let reached = reference.parameter(name).unwrap().estimate;
        let true_value = at_truth_model.parameter(name).unwrap();
        println!(
            "{name}: multi-start {got:.4e}, from the truth {reached:.4e}, truth {true_value:.4e}"
        );
        assert!(
            ((got - reached) / reached).abs() < to_reference,
            "{name}: {got} from 50 % off, {reached} from the truth"
        );
        assert!(
            ((got - true_value) / true_value).abs() < to_truth,
            "{name}: {got} against the truth's {true_value}"
        );
    }
}
