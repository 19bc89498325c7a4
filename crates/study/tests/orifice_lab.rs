//! The valve's ISO 6358 orifice from the lab's tank discharges, the tank's gas simulated with
//! its cooling (#12: the valve known from the lab, so that the valve runs need not tell flow
//! from volume). On the virtual truck and a variant whose valve differs from it.

use airsus_data::{Role, TankDischarge};
use airsus_estimate::submodel::{DischargeData, OrificeFitOptions, fit_linear_valve, fit_orifice};
use airsus_truck::experiments::reference_discharges;
use airsus_truck::lab::DischargeTest;
use airsus_truck::lab::measure_discharge;
use airsus_truck::truth::VirtualTruck;

/// The variant's lab discharges with their metadata, as a study lists them.
fn discharges(truck: &VirtualTruck) -> Vec<(String, DischargeTest, Role, TankDischarge)> {
    reference_discharges()
        .into_iter()
        .enumerate()
        .map(|(i, (name, test, role))| {
            let log = measure_discharge(truck, &test, 40 + i as u64).unwrap();
            (name, test, role, log)
        })
        .collect()
}

fn data(logs: &[(String, DischargeTest, Role, TankDischarge)]) -> Vec<DischargeData<'_>> {
    logs.iter()
        .map(|(name, test, role, log)| DischargeData {
            name: name.clone(),
            discharge: log,
            channel: test.channel,
            tank_volume_m3: test.tank_volume_m3,
            temperature_k: test.temperature_k,
            role: *role,
        })
        .collect()
}

#[test]
fn a_valve_that_is_no_orifice_is_fitted_in_time_and_shows_it() {
    // Variant 3's valve is a linear resistance. Trial points of the orifice fit there made
    // the end of a discharge stiff and the fit ran for minutes; on a step budget they fail
    // and the fit ends, its tank pressures far from the logged ones.
    let truck = VirtualTruck::variant(3);
    assert_eq!(truck.valve_law().tag(), "linear_resistance");
    let logs = discharges(&truck);
    let fit = fit_orifice(
        &data(&logs),
        &OrificeFitOptions::for_truck(&airsus_data::TruckParameters::reference()),
    )
    .unwrap();
    // Measured: 86-87 % on each discharge (an orifice truck's: 99.9 %).
    for d in &fit.discharges {
        assert!(d.nrmse_percent < 95.0, "{d:?}");
    }
}

#[test]
fn the_tank_discharges_give_the_valves_orifice() {
    for k in [0, 2] {
        let mut truck = VirtualTruck::variant(k);
        let logs = discharges(&truck);
        let data = data(&logs);
        truck.resolve_laws();
        let e = &truck.effect_parameters;
        // Started a fifth off in every value.
        let options = OrificeFitOptions {
            start_fill_conductance_m3_s_pa: 4e-9,
            start_exhaust_conductance_m3_s_pa: 1.5e-8,
            start_critical_pressure_ratio: 0.5,
            start_tank_thermal_time_s: 30.0,
            ..OrificeFitOptions::for_truck(&airsus_data::TruckParameters::reference())
        };
        let fit = fit_orifice(&data, &options).unwrap();
        // Measured (variant 0 / 2): c1 4.9998e-9 / 5.6680e-9 (true 5e-9 / 5.6680e-9), c2
        // 1.19994e-8 / 1.47610e-8 (1.2e-8 / 1.47617e-8), b 0.4002 / 0.3164 (0.4 / 0.3164), the
        // rig's wall 60.0 / 60.0 s (60); residual 105 / 104 Pa against the sensor's 100 Pa.
        let close = |got: f64, truth: f64, tolerance: f64| (got / truth - 1.0).abs() < tolerance;
        let c1 = fit.fill_conductance_m3_s_pa.unwrap();
        let c2 = fit.exhaust_conductance_m3_s_pa.unwrap();
        assert!(
            close(c1, e.fill_conductance_m3_s_pa, 0.01)
                && close(c2, e.exhaust_conductance_m3_s_pa, 0.01)
                && (fit.critical_pressure_ratio - e.critical_pressure_ratio).abs() < 0.01
                && close(
                    fit.tank_thermal_time_s,
                    e.lab_tank_thermal_time_constant_s,
                    0.05
                ),
            "variant {k}: {fit:?}"
        );
        assert!(fit.residual_rms_pa < 120.0, "variant {k}: {fit:?}");
        // The held-out discharges (other start pressures) are simulated to their noise.
        for d in &fit.discharges {
            assert!(d.nrmse_percent > 99.8, "variant {k}: {d:?}");
        }
        // It writes into a truck under the orifice law, and refuses one under another law.
        let mut orifice = truck.physical.clone();
        fit.write_to(&mut orifice).unwrap();
        assert_eq!(
            orifice
                .valve
                .get(airsus_data::params::Field::FillConductance),
            Some(c1)
        );
        let mut linear = airsus_data::TruckParameters::reference();
        let err = fit.write_to(&mut linear).unwrap_err().to_string();
        assert!(err.contains("\"linear_resistance\""), "{err}");
        assert_eq!(linear, airsus_data::TruckParameters::reference());
    }
}

#[test]
fn the_discharges_tell_a_linear_valve_from_an_orifice() {
    // Both laws fitted to the same discharges, the tank's gas simulated: the law the valve
    // follows leaves the sensor's noise (100 Pa), the other far more. Measured: variant 3
    // (linear) 107 Pa against 23,777 Pa under the orifice; variant 0 (orifice) 107 Pa against
    // 22,173 Pa under linear resistances.
    let options = OrificeFitOptions::for_truck(&airsus_data::TruckParameters::reference());
    for k in [3, 0] {
        let truck = VirtualTruck::variant(k);
        let logs = discharges(&truck);
        let data = data(&logs);
        let linear = fit_linear_valve(&data, &options).unwrap();
        let orifice = fit_orifice(&data, &options).unwrap();
        let (own, other) = match truck.valve_law() {
            airsus_data::ValveFlowLaw::LinearResistance {
                fill_pa_s_per_mol,
                exhaust_pa_s_per_mol,
            } => {
                // Started from the thesis' 2.5e6 / 1.5e6, the resistances come back to 1 %,
                // the isothermal reading of the thesis (fit_valve) 16 % low on this rig.
                let r1 = linear.fill_resistance_pa_s_per_mol.unwrap();
                let r2 = linear.exhaust_resistance_pa_s_per_mol.unwrap();
                assert!((r1 / fill_pa_s_per_mol - 1.0).abs() < 0.01, "{linear:?}");
                assert!((r2 / exhaust_pa_s_per_mol - 1.0).abs() < 0.01, "{linear:?}");
                let law = linear.law(&options);
                assert_eq!(law.tag(), "linear_resistance");
                (linear.residual_rms_pa, orifice.residual_rms_pa)
            }
            _ => (orifice.residual_rms_pa, linear.residual_rms_pa),
        };
        assert!(own < 120.0, "variant {k}: {own} Pa");
        assert!(
            other > 20.0 * own,
            "variant {k}: {other} Pa against {own} Pa"
        );
    }
}
