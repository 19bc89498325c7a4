//! Road input: linearised vs nonlinear models, and the ISO 8608 generator.

use airsus_apps::road::*;
use airsus_data::{TruckParameters, ValveState};
use airsus_model::submodels::Tire;
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
    linear_error_of(&Model2::new(truck), truck, height)
}

/// [`linear_error`] of any model with a tire.
fn linear_error_of(
    model: &dyn SuspensionModel,
    truck: &TruckParameters,
    height: f64,
) -> (f64, f64, f64) {
    let load = 3390.0;
    let u0 = InputSample {
        wheel_load_kg: load,
        valve: ValveState::Closed,
        supply_gauge_pa: 850e3,
        road_height_m: 0.0,
        road_rate_m_s: 0.0,
    };
    let x0 = model
        .initial_state(&u0, &InitialCondition::SensorHeight { height_m: 0.24 })
        .unwrap();
    let axle = AxleGeometry::of(model, truck).unwrap();
    let lin = linearize(model, &axle, &Tire::new(&truck.tire), &x0, &u0).unwrap();
    let time = time_axis(3.0, 0.002).unwrap();
    let road = bump_road(&time, 10.0, height);
    let nl = simulate_road(model, truck, &time, &road, load, 0.24).unwrap();
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
    // The simulator and the linear model both follow the road linearly between samples
    // (first-order hold); with a held road on one side this was 0.032 / 0.043.
    assert!(h_small < 0.01 && f_small < 0.01);
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

/// #13: every model with a tire, the `truck` structure among them (creep, wall friction, gas
/// heat exchange, the supply line), linearised about rest follows its own nonlinear response
/// to a small bump and not to a large one. "Small" is the wall friction's to say for the
/// `truck` structure: its Dahl law is not linear even before it slides (the force's growth
/// slows as it nears `F_c`, over a pre-sliding travel of about 5 mm of bellow), so its
/// linearisation errs by 0.7 % (height) on a 0.5 mm bump, 1.0 % on 1 mm and 4.1 % on 2 mm,
/// where the other models err by 0.2-0.3 % (and the structure without its wall friction
/// 0.4 %). Measured on a 100 mm bump: 68-73 % (height),
/// 102-114 % (tire force), the wheel leaving the road.
#[test]
fn every_model_with_a_tire_linearises_for_a_small_bump() {
    let truck = symmetric_damper_truck();
    for name in ["m1", "m2", "m2x", "m2xh", "truck"] {
        let model = airsus_truck::models::build_any_model(name, &truck).unwrap();
        let small_m = if name == "truck" { 0.0005 } else { 0.002 };
        let (h_small, f_small, _) = linear_error_of(model.as_ref(), &truck, small_m);
        let (h_large, f_large, _) = linear_error_of(model.as_ref(), &truck, 0.10);
        println!(
            "{name}: {} mm bump height error {h_small:.4}, tire force {f_small:.4}; 100 mm {h_large:.4}, {f_large:.4}",
            small_m * 1e3
        );
        assert!(
            h_small < 0.01 && f_small < 0.01,
            "{name}: {h_small} {f_small}"
        );
        assert!(
            h_large > 0.5 && f_large > 0.5,
            "{name}: {h_large} {f_large}"
        );
    }
    let wall = airsus_truck::models::build_any_model("truck", &truck).unwrap();
    let (h_2mm, _, _) = linear_error_of(wall.as_ref(), &truck, 0.002);
    assert!(h_2mm > 0.02, "the wall friction's pre-sliding: {h_2mm}");
    // Without the wall friction the structure linearises as the others do.
    let mut frictionless = truck.clone();
    frictionless.effects.friction_force_n = Some(0.0);
    let smooth = airsus_truck::models::build_any_model("truck", &frictionless).unwrap();
    let (h, f, _) = linear_error_of(smooth.as_ref(), &frictionless, 0.002);
    println!("truck without wall friction: 2 mm bump height error {h:.4}, tire force {f:.4}");
    assert!(h < 0.01 && f < 0.01, "{h} {f}");
}

/// A tire with a damper beside its spring (#13 item 2): the linearised model, which takes the
/// road's rate as an input of its own, follows the simulator, which feeds each road segment's
/// slope to the tire; and the damper takes energy out of the wheel hop, so the tire force
/// swings less over the same bump.
#[test]
fn a_damped_tire_is_followed_linearised_and_calms_the_wheel_hop() {
    let mut damped = symmetric_damper_truck();
    damped.tire.damping_n_s_per_m = 4000.0;
    let (h, f, _) = linear_error(&damped, 0.002);
    println!("2 mm bump, damped tire: height error {h:.4}, tire force error {f:.4}");
    assert!(h < 0.01 && f < 0.01, "{h} {f}");
    let swing = |truck: &TruckParameters| {
        let time = time_axis(3.0, 0.002).unwrap();
        let road = bump_road(&time, 10.0, 0.02);
        let r = simulate_road(&Model2::new(truck), truck, &time, &road, 3390.0, 0.24).unwrap();
        r.summary.dynamic_load_coefficient
    };
    let (plain, calmed) = (swing(&symmetric_damper_truck()), swing(&damped));
    println!("20 mm bump: dynamic load coefficient {plain:.4} plain, {calmed:.4} damped tire");
    assert!(calmed < 0.95 * plain, "{plain} {calmed}");
}

/// ISO 8608:2016 Table 1, `Gd(n0)` at n0 = 0.1 cycles/m, geometric mean of each class, in
/// 10⁻⁶ m³, written out here (not read from the crate) so that the check is independent.
const ISO8608_TABLE_1E6_M3: [(char, f64); 5] = [
    ('A', 16.0),
    ('B', 64.0),
    ('C', 256.0),
    ('D', 1024.0),
    ('E', 4096.0),
];

/// The structure function `D(Δ) = E[(z(s+Δ) - z(s))²] = 2 ∫ G(n) (1 - cos 2πnΔ) dn` of the
/// ISO 8608 PSD `G(n) = Gd(n0) (n0/n)²` over the band `[n1, n2]`, by Simpson's rule: an
/// independent reference that shares neither the generator's sum of cosines nor a PSD
/// estimator.
fn structure_function_m2(gd_n0_m3: f64, n1: f64, n2: f64, lag_m: f64) -> f64 {
    let steps = 200_000;
    let h = (n2 - n1) / steps as f64;
    let f = |n: f64| {
        2.0 * gd_n0_m3 * (0.1 / n).powi(2) * (1.0 - (2.0 * std::f64::consts::PI * n * lag_m).cos())
    };
    let mut sum = f(n1) + f(n2);
    for i in 1..steps {
        let n = n1 + i as f64 * h;
        sum += if i % 2 == 1 { 4.0 } else { 2.0 } * f(n);
    }
    sum * h / 3.0
}

#[test]
fn iso8608_generator_has_the_class_psd() {
    let ds = 0.05;
    let (n1, n2) = (0.011, 2.83);
    let s: Vec<f64> = (0..40_000).map(|k| k as f64 * ds).collect();
    for (class, seed) in [('C', 1), ('A', 2), ('E', 3)] {
        let table = ISO8608_TABLE_1E6_M3
            .iter()
            .find(|(c, _)| *c == class)
            .unwrap()
            .1
            * 1e-6;
        assert_eq!(iso8608_gd_n0_m3(class).unwrap(), table, "class {class}");
        let road = Iso8608Road::new(class, n1, n2, 4000, seed).unwrap();
        let z = road.heights_m(&s);
        // Height differences at lags from 0.5 m (short waves) to 10 m (long waves) against the
        // class's analytic structure function: each lag weighs another part of the spectrum,
        // so a wrong slope or level shows.
        for lag_m in [0.5, 1.0, 2.0, 5.0, 10.0] {
            let k = (lag_m / ds).round() as usize;
            let d_measured =
                z.windows(k + 1).map(|w| (w[k] - w[0]).powi(2)).sum::<f64>() / (z.len() - k) as f64;
            let d_expected = structure_function_m2(table, n1, n2, lag_m);
            println!(
                "class {class}, lag {lag_m} m: D {:.3e} m² (analytic {:.3e})",
                d_measured, d_expected
            );
            assert!(
                (d_measured / d_expected - 1.0).abs() < 0.2,
                "class {class}, lag {lag_m} m: {d_measured:e} vs {d_expected:e}"
            );
        }
        // Total variance: ∫ G dn = Gd(n0) n0² (1/n1 - 1/n2), analytic.
        let var = z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64;
        let var_expected = table * 0.01 * (1.0 / n1 - 1.0 / n2);
        assert!(
            (var / var_expected - 1.0).abs() < 0.3,
            "class {class}: variance {var:e} vs {var_expected:e}"
        );
    }
    assert!(iso8608_gd_n0_m3('Z').is_err());
}

#[test]
fn model_3_has_no_tire() {
    let truck = TruckParameters::reference();
    let m3 = airsus_model::build_model("m3", &truck).unwrap();
    assert!(AxleGeometry::of(m3.as_ref(), &truck).is_err());
}

/// #13: the tire force the study's estimate simulates over a road it never saw (an ISO 8608
/// class C road at 50 km/h, a new seed) matches the one the virtual truck's own structure
/// simulates (its truth as a file of the `truck` structure), on variants 0-3: the road
/// parameters the study took from its road run (damper scale, tire, unsprung mass) hold on
/// another road. Both from the same equilibrium at the run's first height and its load.
#[test]
fn the_study_estimate_s_tire_force_on_a_new_road_matches_the_truth_s() {
    use airsus_truck::experiments::run_experiment;
    use airsus_truck::model::TruckModel;
    use airsus_truck::scenario::road_2;
    use airsus_truck::truth::VirtualTruck;
    for k in 0..=3u32 {
        let mut truck = VirtualTruck::variant(k);
        let (m2, friction) = (
            truck.physical.mass.unsprung_kg,
            truck.effect_parameters.friction_force_n,
        );
        let seed = 300 + u64::from(k);
        let road = run_experiment(&truck, &road_2(m2, seed).unwrap(), friction, seed).unwrap();
        truck.resolve_laws();
        let fixture = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join(format!("tests/fixtures/study_truck_variant{k}.toml"));
        let estimate = airsus_data::read_truck(&fixture).unwrap().parameters;
        let (time, road_m) = (&road.logged.time_s, &road.logged.inputs.road_height_m);
        let load_kg = road.truth.inputs.wheel_load_kg[0];
        let height_m = road.logged.measured().unwrap().sensor_height_m[0];
        let tire_force = |p: &TruckParameters| {
            let model = TruckModel::from_truck_parameters(p);
            simulate_road(&model, p, time, road_m, load_kg, height_m)
                .unwrap()
                .tire_force_n
        };
        let (truth, estimated) = (tire_force(&truck.physical), tire_force(&estimate));
        let fit = airsus_validate::nrmse_percent(&truth, &estimated).unwrap();
        let rms_n = (truth
            .iter()
            .zip(&estimated)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / truth.len() as f64)
            .sqrt();
        println!("variant {k}: tire force NRMSE {fit:.2} % (rms difference {rms_n:.0} N)");
        // Measured 99.18, 99.65, 99.58 and 96.72 %. Before the study refitted the damper's
        // scale, the tire's stiffness and the lever's inertia on its road run alone, 99.61,
        // 99.35, 97.30 and 89.91 %: variant 3's tires are 14 % stiffer (2.05 MN/m) than the
        // file's 1.8 MN/m, which the joint fit kept, and it took the lever's inertia 12 % low
        // to make up (the truth's stiffness alone then gave 88.4 %). Refitted: kw 1.96 MN/m,
        // ig 185 kg m² against the truth's 193.
        assert!(fit > 96.0, "variant {k}: {fit:.2} %");
    }
}
