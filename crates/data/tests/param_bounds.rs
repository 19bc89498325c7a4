//! One declaration per parameter: the truck-file reader rejects a value outside the range
//! declared in `airsus_data::params` — the same range the models and the estimator use — and
//! names the file, line, key and bound.

use std::path::Path;

use airsus_data::params::{CATALOG, Field, MAX_AREA_KNOTS, MAX_DAMPER_CORRECTIONS, get, set};
use airsus_data::truck::parse_truck;
use airsus_data::{EffectiveAreaLaw, GasVolumeLaw, TruckParameters, ValveFlowLaw, truck_to_toml};

fn reference_with_optional_keys() -> TruckParameters {
    let mut truck = TruckParameters::reference();
    truck.slow_dynamics.force_scale = Some(1000.0);
    truck.slow_dynamics.creep_stiffness_n_per_m = Some(2.5e4);
    truck.slow_dynamics.creep_time_constant_s = Some(33.0);
    truck
}

/// The same with the other laws and every `[effects]` value, so each declared parameter has
/// a home in one of the two trucks.
fn reference_with_other_laws() -> TruckParameters {
    let mut truck = reference_with_optional_keys();
    truck.bellow.effective_area = EffectiveAreaLaw::PressurePolynomial {
        coefficients_m2: *truck.bellow.effective_area.coefficients_m2().unwrap(),
        growth_per_100kpa: 0.004,
    };
    truck.bellow.gas_volume = GasVolumeLaw::AreaIntegral {
        dead_volume_m3: 0.05,
        bellows: 2,
    };
    truck.valve = ValveFlowLaw::Orifice {
        fill_conductance_m3_s_pa: 5e-9,
        exhaust_conductance_m3_s_pa: 1.2e-8,
        critical_pressure_ratio: 0.4,
    };
    for (field, value) in [
        (Field::WallCreepStiffness, 18e3),
        (Field::WallCreepTime, 25.0),
        (Field::WallFrictionForce, 120.0),
        (Field::WallFrictionStiffness, 2e4),
        (Field::GasThermalTime, 20.0),
        (Field::LineResistance, 4e5),
    ] {
        assert!(set(&mut truck, field, value));
    }
    truck
}

/// The reference with a spline effective area of the most knots a spline has.
fn reference_with_a_spline() -> TruckParameters {
    let mut truck = reference_with_optional_keys();
    let heights: Vec<f64> = (0..MAX_AREA_KNOTS).map(|i| 0.2 + 0.02 * i as f64).collect();
    let areas = heights
        .iter()
        .map(|&h| truck.bellow.effective_area.area_m2(h, 0.0))
        .collect();
    truck.bellow.effective_area = EffectiveAreaLaw::spline(heights, areas, Some(0.004)).unwrap();
    // And a damper table of the most points that carry corrections, each corrected.
    let n = MAX_DAMPER_CORRECTIONS;
    truck.damper.velocity_m_s = (0..n).map(|i| -1.1 + 0.2 * i as f64).collect();
    truck.damper.force_n = truck
        .damper
        .velocity_m_s
        .iter()
        .map(|v| 4000.0 * v)
        .collect();
    truck.damper.correction = (0..n).map(|i| 0.8 + 0.04 * i as f64).collect();
    truck
}

#[test]
fn every_declared_parameter_is_range_checked_at_load_with_its_declared_bounds() {
    let path = Path::new("truck.toml");
    let trucks = [
        reference_with_optional_keys(),
        reference_with_other_laws(),
        reference_with_a_spline(),
    ];
    for truck in &trucks {
        let text = truck_to_toml(truck);
        let loaded = parse_truck(&text, path).expect("the reference truck loads");
        assert_eq!(&loaded.parameters, truck, "{text}");
    }

    for param in CATALOG {
        // The first truck whose laws have this parameter.
        let reference = trucks
            .iter()
            .find(|t| !get(t, param.field).is_nan())
            .unwrap_or_else(|| panic!("`{}` has a home in no truck", param.info.name));
        let info = &param.info;
        let (section, key, index) = param.field.location();
        let shown = match index {
            Some(i) => format!("{section}.{key}[{i}]"),
            None => format!("{section}.{key}"),
        };
        let below = if info.lower > 0.0 {
            info.lower * 0.5
        } else {
            info.lower - 0.01 * (info.upper - info.lower)
        };
        let above = info.upper * 2.0;
        for outside in [below, above] {
            let mut truck = reference.clone();
            assert!(set(&mut truck, param.field, outside));
            let err = parse_truck(&truck_to_toml(&truck), path)
                .expect_err(&format!("{shown} = {outside} must be refused"))
                .to_string();
            assert!(err.contains(&shown), "{shown}: {err}");
            assert!(
                err.contains(&format!("{} to {} {}", info.lower, info.upper, info.unit)),
                "{shown}: the declared bounds in {err}"
            );
            // file:line: the error points at the key's line.
            let line = err
                .strip_prefix("truck.toml:")
                .and_then(|rest| rest.split(':').next())
                .and_then(|l| l.parse::<usize>().ok())
                .unwrap_or_else(|| panic!("{shown}: no line in {err}"));
            let key_line = truck_to_toml(&truck)
                .lines()
                .nth(line - 1)
                .unwrap()
                .to_owned();
            assert!(
                key_line.trim_start().starts_with(key),
                "{shown}: line {line} is `{key_line}`"
            );
        }
    }
}

#[test]
fn a_default_is_never_refused_only_what_the_file_says() {
    // A light axle on a short lever: the lever inertia's default m2 l1² (0.9 kg m²) lies
    // below ig's admissible range, but the file did not write it.
    let mut truck = TruckParameters::reference();
    truck.mass.unsprung_kg = 10.0;
    truck.geometry.l1_m = 0.3;
    let text = truck_to_toml(&truck)
        .lines()
        .filter(|l| !l.trim_start().starts_with("lever_inertia_kg_m2"))
        .collect::<Vec<_>>()
        .join("\n");
    let loaded = parse_truck(&text, Path::new("light.toml")).expect("loads");
    assert!((loaded.parameters.mass.lever_inertia_kg_m2 - 0.9).abs() < 1e-12);
    assert!(
        loaded
            .defaulted
            .iter()
            .any(|d| d.key == "mass.lever_inertia_kg_m2")
    );
}
