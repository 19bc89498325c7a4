//! The load the wheel felt, from a log that steps: with the virtual truck's own structure at
//! its true parameters, the transition time fitted to data-set 1 lies among the ramps the
//! truck really made (3 to 8 s, a different one per step, smoothstep), and easing the steps
//! removes most of the loss they caused. The fit does not know the ramps; it sees the
//! logged steps and the measurements, as on a real truck.

use airsus_data::read_run;
use airsus_estimate::{GreyboxProblem, fit_load_ramp, ramp_logged_load};
use airsus_truck::models::build_any_model;

#[test]
fn the_fitted_transition_lies_among_the_true_ramps_and_removes_most_of_the_loss() {
    let dir = tempfile::tempdir().unwrap();
    airsus_truck::experiments::generate(dir.path(), 2, &mut |_| {}).unwrap();
    let ds1 = read_run(&dir.path().join("ds1.csv")).unwrap();
    let truth = airsus_data::read_truck(&dir.path().join("truth/truck.toml"))
        .unwrap()
        .parameters;
    let model = build_any_model("truck", &truth).unwrap();
    let problem = GreyboxProblem::new(&*model, &[&ds1], &[]);
    let fit = fit_load_ramp(&problem).unwrap();
    assert!(
        (3.0..=8.0).contains(&fit.duration_s),
        "fitted {} s",
        fit.duration_s
    );
    assert!(
        fit.loss_ramped < 0.5 * fit.loss_logged,
        "loss {} as logged, {} eased",
        fit.loss_logged,
        fit.loss_ramped
    );
    // The eased load is the log's between changes: only the transitions differ.
    let eased = ramp_logged_load(&ds1, fit.duration_s);
    let differ = eased
        .inputs
        .wheel_load_kg
        .iter()
        .zip(&ds1.inputs.wheel_load_kg)
        .filter(|(a, b)| (*a - *b).abs() > 1e-9)
        .count();
    let changes = ds1
        .inputs
        .wheel_load_kg
        .windows(2)
        .filter(|w| w[0] != w[1])
        .count();
    assert!(differ <= changes * (fit.duration_s / ds1.sample_time_s).ceil() as usize);
}
