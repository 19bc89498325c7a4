//! The study's submodel stage keeps the laws a truck file chose. It used to write the thesis'
//! linear valve resistances over an ISO 6358 orifice law (and the `truck` structure then
//! started from its built-in conductances, whatever the file said), and its cross-section fit
//! over any gas-volume law. An orifice file now gets the orifice the tank discharges give.

use airsus_data::{GasVolumeLaw, ValveFlowLaw};
use airsus_study::load_study;
use airsus_study::submodels::fit_submodels;

#[test]
fn the_submodel_stage_keeps_an_orifice_valve_and_an_area_integral_volume() {
    let dir = tempfile::tempdir().unwrap();
    let generated = airsus_truck::experiments::generate(dir.path(), 1, &mut |_| {}).unwrap();
    let mut input = load_study(&generated.study_valve).unwrap();
    input.truck.valve = ValveFlowLaw::Orifice {
        fill_conductance_m3_s_pa: 5.5e-9,
        exhaust_conductance_m3_s_pa: 1.3e-8,
        critical_pressure_ratio: 0.35,
    };
    let volume = GasVolumeLaw::AreaIntegral {
        dead_volume_m3: 0.05,
        bellows: 2,
    };
    input.truck.bellow.gas_volume = volume.clone();
    let estimation: Vec<String> = ["data-set 1", "data-set 3"].map(str::to_owned).to_vec();
    let (start, fits) = fit_submodels(&input, &estimation);
    // The file names the orifice and holds the lab's: every model runs it.
    assert_eq!(start.lab_valve, None);
    let start = start.truck;
    // The orifice law stays, with the values the discharges give (the virtual truck's valve:
    // 5e-9 and 1.2e-8 m3/(s Pa), b 0.4), from the tank's gas simulated as it cools.
    let ValveFlowLaw::Orifice {
        fill_conductance_m3_s_pa: c1,
        exhaust_conductance_m3_s_pa: c2,
        critical_pressure_ratio: b,
    } = start.valve
    else {
        panic!("the orifice law was replaced: {:?}", start.valve);
    };
    assert!(
        (c1 / 5e-9 - 1.0).abs() < 0.01
            && (c2 / 1.2e-8 - 1.0).abs() < 0.01
            && (b - 0.4).abs() < 0.01,
        "{:?}",
        start.valve
    );
    let lab = fits.get("valve_orifice").unwrap();
    assert!(
        lab.notes.iter().any(|n| n.starts_with("written")),
        "{lab:?}"
    );
    assert_eq!(start.bellow.gas_volume, volume);

    // The discharges' resistances are still reported, beside the law they do not replace.
    for name in ["fill_valve", "exhaust_valve"] {
        let fit = fits.get(name).unwrap();
        assert!(fit.error.is_none(), "{name}: {:?}", fit.error);
        assert!(!fit.parameters.is_empty(), "{name}");
        assert!(
            fit.notes
                .iter()
                .any(|n| n.contains("reported, not written") && n.contains("`orifice`")),
            "{name}: {:?}",
            fit.notes
        );
    }
    let cross = fits.get("cross_section").unwrap();
    assert!(
        cross
            .error
            .as_deref()
            .is_some_and(|e| e.contains("`area_integral`")),
        "{cross:?}"
    );

    // The reference file (the thesis' laws) still gets both fits written.
    let input = load_study(&generated.study_valve).unwrap();
    let (start, fits) = fit_submodels(&input, &estimation);
    // The file names no law: the lab's discharges call for the orifice (their residual is
    // the sensor's under it, 200 times that under linear resistances), which the `truck`
    // structure starts from; Model 2 keeps the thesis' resistances.
    let Some(ValveFlowLaw::Orifice {
        fill_conductance_m3_s_pa: c1,
        critical_pressure_ratio: b,
        ..
    }) = start.lab_valve
    else {
        panic!("{:?}", start.lab_valve);
    };
    assert!(
        (c1 / 5e-9 - 1.0).abs() < 0.01 && (b - 0.4).abs() < 0.01,
        "{c1} {b}"
    );
    let structure = start.truck_for(airsus_truck::models::model_entry("truck").unwrap());
    assert_eq!(structure.valve, start.lab_valve.unwrap());
    let m2 = start.truck_for(airsus_truck::models::model_entry("m2").unwrap());
    assert_eq!(m2, start.truck);
    let linear = fits.get("valve_linear").unwrap();
    assert!(
        linear
            .notes
            .iter()
            .any(|n| n.contains("Pa under linear resistances")),
        "{linear:?}"
    );
    let start = start.truck;
    assert_eq!(start.valve.tag(), "linear_resistance");
    assert_ne!(start.valve, input.truck.valve);
    assert!(fits.get("fill_valve").unwrap().notes.len() == 1);
    // The orifice is reported beside them, not written over the thesis' law.
    let lab = fits.get("valve_orifice").unwrap();
    assert!(
        lab.notes
            .iter()
            .any(|n| n.contains("reported, not written")),
        "{lab:?}"
    );
    assert_ne!(start.bellow.gas_volume, input.truck.bellow.gas_volume);
}

/// Model 3's height block is the one submodel each protocol identifies on its own runs (the
/// registry says so, `height_block_per_protocol`): the submodel stage identifies it on the
/// first protocol's runs (here the thesis' data-set 1), and a protocol that also estimates
/// on a levelling run, whose controller moves the air while the load steps, starts Model 3
/// from a block identified there. The other models start as the stage left them.
#[test]
fn each_protocol_starts_model_3_from_a_height_block_of_its_own_runs() {
    let dir = tempfile::tempdir().unwrap();
    let generated = airsus_truck::experiments::generate(dir.path(), 1, &mut |_| {}).unwrap();
    let input = load_study(&generated.study_valve).unwrap();
    let names = |runs: &[&str]| runs.iter().map(|r| r.to_string()).collect::<Vec<String>>();
    let thesis = names(&["data-set 1"]);
    let ours = names(&["data-set 1", "data-set 3", "levelling 1", "road 1"]);
    let (start, _) = fit_submodels(&input, &thesis);
    assert_eq!(start.model3_oe_run.as_deref(), Some("data-set 1"));
    let m3 = airsus_truck::models::model_entry("m3").unwrap();
    // The protocol the stage ran on: its block, nothing said.
    let (same, notes) = start.truck_for_protocol(m3, &input, &thesis);
    assert_eq!(same, start.truck_for(m3));
    assert!(notes.is_empty(), "{notes:?}");
    // Our protocol: identified on the levelling run, and said.
    let (own, notes) = start.truck_for_protocol(m3, &input, &ours);
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].starts_with("the OE height model re-identified on levelling 1"),
        "{notes:?}"
    );
    assert_ne!(own.model3, start.truck.model3);
    // Only the block differs.
    let mut only_block = own.clone();
    only_block.model3 = start.truck.model3.clone();
    assert_eq!(only_block, start.truck_for(m3));
    for name in ["m1", "m2", "m2x", "m2xh", "truck"] {
        let entry = airsus_truck::models::model_entry(name).unwrap();
        let (truck, notes) = start.truck_for_protocol(entry, &input, &ours);
        assert_eq!(truck, start.truck_for(entry), "{name}");
        assert!(notes.is_empty(), "{name}: {notes:?}");
    }
}
