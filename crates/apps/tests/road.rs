//! Road input: linearised vs nonlinear Model 2, and the ISO 8608 generator.

use airsus_apps::road::*;
use airsus_data::{TruckParameters, ValveState};
use airsus_model::{InitialCondition, InputSample, Model2, SuspensionModel};

/// The reference truck with a damper of one slope through zero (22.5 kN s/m up to 0.1 m/s):
/// the table's different compression and rebound slopes have no derivative at rest.
fn symmetric_damper_truck() -> TruckParameters {
    let mut t = TruckParameters::reference();
    t.damper.velocity_m_s = vec![-1.0, -0.5, -0.1, 0.0, 0.1, 0.5, 1.0];
    t.damper.force_n = vec![-11000.0, -6500.0, -2250.0, 0.0, 2250.0, 6500.0, 11000.0];
    t
}

fn bump_road(time: &[f64], speed: f64, height: f64) -> Vec<f64> {
    time.iter()
        .map(|&t| half_sine_bump_m(t * speed, speed * 0.5, 1.0, height))
        .collect()
}

/// `‖y_nl - y_lin‖ / ‖y_nl - y0‖` for the sensor height and the tire force.
fn linear_error(truck: &TruckParameters, height: f64) -> (f64, f64, f64) {
    let model = Model2::new(truck);
    let load = 3390.0;
    let u0 = InputSample {
        wheel_load_kg: load,
        valve: ValveState::Closed,
        supply_gauge_pa: 850e3,
        road_height_m: 0.0,
    };
    let x0 = model
        .initial_state(&u0, &InitialCondition::SensorHeight { height_m: 0.24 })
        .unwrap();
    let axle = AxleGeometry::of(&model, truck).unwrap();
    let lin = linearize(&model, &axle, truck.tire.stiffness_n_per_m, &x0, &u0).unwrap();
    let time = time_axis(3.0, 0.002).unwrap();
    let road = bump_road(&time, 10.0, height);
    let nl = simulate_road(&model, truck, &time, &road, load, 0.24).unwrap();
    let li = simulate_linear(&lin, &time, &road).unwrap();
    let rel = |i: usize, nl: &[f64]| {
        let (mut num, mut den) = (0.0, 0.0);
        for (k, &y) in nl.iter().enumerate() {
            num += (y - li[k][i]).powi(2);
            den += (y - lin.y0[i]).powi(2);
        }
        (num / den).sqrt()
    };
    (
        rel(0, &nl.sensor_height_m),
        rel(1, &nl.tire_force_n),
        nl.summary.contact_loss_fraction,
    )
}

#[test]
fn linearised_model_2_matches_for_a_small_bump_and_not_for_a_large_one() {
    let truck = symmetric_damper_truck();
    let (h_small, f_small, loss_small) = linear_error(&truck, 0.002);
    println!("2 mm bump: height error {h_small:.4}, tire force error {f_small:.4}");
    assert!(h_small < 0.02 && f_small < 0.02);
    assert_eq!(loss_small, 0.0);
    let (h_large, f_large, loss_large) = linear_error(&truck, 0.10);
    println!(
        "100 mm bump: height error {h_large:.4}, tire force error {f_large:.4}, contact loss {loss_large:.3}"
    );
    assert!(loss_large > 0.0, "the wheel leaves the road");
    assert!(f_large > 0.1 && h_large > 0.05);
    // The reference damper (different slopes in compression and rebound) is not linearisable
    // at rest: even the small bump shows it.
    let (h_ref, f_ref, _) = linear_error(&TruckParameters::reference(), 0.002);
    println!("2 mm bump, reference damper: height error {h_ref:.4}, tire force error {f_ref:.4}");
    assert!(h_ref > h_small);
}

#[test]
fn iso8608_generator_has_the_class_psd() {
    let ds = 0.05;
    let s: Vec<f64> = (0..40_000).map(|k| k as f64 * ds).collect();
    for (class, seed) in [('C', 1), ('A', 2), ('E', 3)] {
        let road = Iso8608Road::new(class, 0.011, 2.83, 4000, seed).unwrap();
        let z = road.heights_m(&s);
        // Estimated PSD at 40 log-spaced frequencies in 0.05..1 cycles/m, 10 segments of 200 m.
        let freqs: Vec<f64> = (0..40)
            .map(|i| 0.05 * (20f64).powf(i as f64 / 39.0))
            .collect();
        let psd = estimate_psd_m3(&z, ds, 10, &freqs);
        // Fit log Gd = log Gd(n0) - w log(n/n0) by least squares.
        let xs: Vec<f64> = freqs.iter().map(|n| (n / ISO8608_N0).ln()).collect();
        let ys: Vec<f64> = psd.iter().map(|g| g.ln()).collect();
        let m = xs.len() as f64;
        let (mx, my) = (xs.iter().sum::<f64>() / m, ys.iter().sum::<f64>() / m);
        let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
        let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
        let slope = sxy / sxx;
        let gd_n0 = (my - slope * mx).exp();
        let expected = iso8608_gd_n0_m3(class).unwrap();
        println!(
            "class {class}: slope {slope:.3}, Gd(n0) {:.1}e-6 (class {:.0}e-6)",
            gd_n0 * 1e6,
            expected * 1e6
        );
        assert!((slope + 2.0).abs() < 0.15, "slope {slope}");
        assert!((gd_n0 / expected - 1.0).abs() < 0.25, "Gd(n0) {gd_n0}");
        // And the variance is what the band carries.
        let var = z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64;
        assert!((var / road.variance_m2() - 1.0).abs() < 0.3, "{var}");
    }
    assert!(iso8608_gd_n0_m3('Z').is_err());
}

#[test]
fn model_3_has_no_tire() {
    let truck = TruckParameters::reference();
    let m3 = airsus_model::build_model("m3", &truck).unwrap();
    assert!(AxleGeometry::of(m3.as_ref(), &truck).is_err());
}
